#!/usr/bin/env python3
"""lucent's normal and bump maps against Mitsuba 3's `normalmap` and `bumpmap`, pixel by pixel.

A square (an OBJ with `vt`, u across, v up) faces the camera under a directional light that
comes from the upper right and a dim constant environment (`path`, max_depth 2: the square
cannot see itself). Its material is tilted by

* a normal map (linear EXR): tangent-space normals that lean along u in rings and along v in
  stripes, so that a swapped, mirrored or turned tangent frame shows;
* a bump map (linear EXR): a height field of bumps that grow across u and ripples along v,
  `height` in lucent = Mitsuba's `scale`.

Each under a diffuse albedo of 0.6 (Mitsuba: `diffuse` inside `normalmap` / `bumpmap`, one-sided)
a rough gold (GGX α 0.2, `roughconductor` with `distribution = "ggx"` and lucent's
`masking = "separable"`) and an anisotropic rough copper (α_u 0.05 along ∂p/∂u, α_v 0.3), whose
unmapped image checks the tangent frame itself; and `blend` of the diffuse (weight 0) and the
gold (weight 1) at weight 0.3 and at a textured weight (the heights image, 0.1–0.9), lucent's
`blend` against Mitsuba's `blendbsdf`. The script prints lucent / Mitsuba of the luminance: the median and
the 10th–90th percentiles over 4 × 4 blocks of the pixels that see the square, and the same
for the plain (unmapped) material, whose image differs, as the check that the maps matter.

    /tmp/py/bin/python benches-peers/mitsuba_normalmap.py [--lucent target/release/lucent]
        [--spp 256] [--variant scalar_spectral] [--save DIR] [--json]

Needs numpy and mitsuba==3.9.1.
"""

import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from peer_common import blocks, peer_args, render_luminance  # noqa: E402

LUMA = np.array([0.2126, 0.7152, 0.0722])
N_CAM, N_TEX, FOV_DEG, DIST, HEIGHT = 96, 64, 40.0, 3.0, 0.12
LIGHT_DIR = [-1.0, -1.0, 1.5]  # the way the light travels: from the upper right, towards the square


def write_inputs(work):
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    x = (np.arange(N_TEX) + 0.5) / N_TEX
    U, V = np.meshgrid(x, 1.0 - x)  # rows top to bottom: v = 1 at the top row
    # Tangent-space normals: rings of tilt along u, stripes of tilt along v.
    r = np.hypot(U - 0.3, V - 0.6)
    nx = 0.6 * np.sin(2 * np.pi * 3 * r)
    ny = 0.5 * np.sign(np.sin(2 * np.pi * 2.5 * V)) * (U > 0.5)
    n = np.stack([nx, ny, np.ones_like(U)], axis=2)
    n /= np.linalg.norm(n, axis=2, keepdims=True)
    mi.Bitmap(((n + 1) / 2).astype(np.float32)).write(os.path.join(work, "normals.exr"))
    h = 0.5 + 0.25 * U * np.sin(2 * np.pi * 4 * U) + 0.15 * np.cos(2 * np.pi * 3 * V)
    mi.Bitmap(np.repeat(h[:, :, None], 3, axis=2).astype(np.float32)).write(os.path.join(work, "heights.exr"))
    with open(os.path.join(work, "square.obj"), "w") as f:
        f.write("v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\n")
        f.write("vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n")
        f.write("vn 0 0 -1\nvn 0 0 -1\nvn 0 0 -1\nvn 0 0 -1\n")
        f.write("f 1/1/1 3/3/3 2/2/2\nf 1/1/1 4/4/4 3/3/3\n")  # wound to face the camera (-z)


MATERIALS = {
    "diffuse": ('type = "lambertian"\nalbedo = 0.6', {"type": "diffuse", "reflectance": {"type": "spectrum", "value": 0.6}}),
    "conductor": ('type = "rough_conductor"\nmetal = "au"\nalpha = 0.2\nmasking = "separable"',
                  {"type": "roughconductor", "material": "Au", "alpha": 0.2, "distribution": "ggx"}),
    # Anisotropic: alpha_u along dp/du in both (the plain case checks the tangent frame).
    "anisotropic": ('type = "rough_conductor"\nmetal = "cu"\nalpha = [0.05, 0.3]\nmasking = "separable"',
                    {"type": "roughconductor", "material": "Cu", "alpha_u": 0.05, "alpha_v": 0.3, "distribution": "ggx"}),
    # blendbsdf: the diffuse (weight 0) and the gold (weight 1), by a constant and by a texture.
    "blend": ('type = "blend"\nmaterials = ["pa", "pb"]\nweight = 0.3', "blend", 0.3),
    "blend_textured": ('type = "blend"\nmaterials = ["pa", "pb"]\nweight = { texture = "heights.exr" }', "blend", "texture"),
}
# The blends' two materials (lucent tables after the blend's own keys).
BLEND_PARTS = """
[materials.pa]
type = "lambertian"
albedo = 0.6
[materials.pb]
type = "rough_conductor"
metal = "au"
alpha = 0.2
masking = "separable"
"""
MAPS = {
    "plain": ("", None),
    "normal": ('normal_map = { texture = "normals.exr" }', "normal"),
    "bump": (f'bump_map = {{ texture = "heights.exr", height = {HEIGHT} }}', "bump"),
}


def render_lucent(lucent, work, spp, mat, mp):
    scene = f"""unit = "m"
camera = {{ eye = [0, 0, -{DIST}], look_at = [0, 0, 0], up = [0, 1, 0], vfov_deg = {FOV_DEG}, width = {N_CAM}, height = {N_CAM} }}
[integrator]
type = "path"
max_depth = 2
[materials.m]
two_sided = false
{MATERIALS[mat][0]}
{MAPS[mp][0]}
{BLEND_PARTS if mat.startswith("blend") else ""}
[[objects]]
material = "m"
mesh = "square.obj"
[[lights]]
type = "directional"
direction = {LIGHT_DIR}
irradiance = 3.0
[[lights]]
type = "environment"
radiance = 0.05
"""
    return render_luminance(lucent, work, f"lucent-{mat}-{mp}", scene, spp)


def render_mitsuba(variant, work, spp, mat, mp):
    import mitsuba as mi

    mi.set_variant(variant)
    T = mi.ScalarTransform4f
    if mat.startswith("blend"):
        w = MATERIALS[mat][2]
        weight = {"type": "bitmap", "raw": True, "filename": os.path.join(work, "heights.exr")} if w == "texture" else w
        bsdf = {"type": "blendbsdf", "weight": weight, "a": dict(MATERIALS["diffuse"][1]), "b": dict(MATERIALS["conductor"][1])}
    else:
        bsdf = dict(MATERIALS[mat][1])
    if MAPS[mp][1] == "normal":
        bsdf = {"type": "normalmap", "normalmap": {"type": "bitmap", "raw": True, "filename": os.path.join(work, "normals.exr")}, "bsdf": bsdf}
    elif MAPS[mp][1] == "bump":
        bsdf = {"type": "bumpmap", "heights": {"type": "bitmap", "raw": True, "filename": os.path.join(work, "heights.exr")}, "scale": HEIGHT, "bsdf": bsdf}
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 2},
        "sensor": {
            "type": "perspective", "fov": FOV_DEG, "fov_axis": "y",
            "to_world": T().look_at(origin=[0, 0, -DIST], target=[0, 0, 0], up=[0, 1, 0]),
            "film": {"type": "hdrfilm", "width": N_CAM, "height": N_CAM, "pixel_format": "rgb", "rfilter": {"type": "box"}},
            "sampler": {"type": "independent", "sample_count": spp},
        },
        "square": {"type": "obj", "filename": os.path.join(work, "square.obj"), "bsdf": bsdf},
        "sun": {"type": "directional", "direction": LIGHT_DIR, "irradiance": {"type": "spectrum", "value": 3.0}},
        "env": {"type": "constant", "radiance": {"type": "spectrum", "value": 0.05}},
    })
    return np.array(mi.render(scene, seed=1), dtype=np.float64)


def main():
    a, work, _tmp = peer_args(__doc__, 256)
    write_inputs(work)
    f = (N_CAM / 2) / np.tan(np.radians(FOV_DEG / 2))
    half = f / DIST
    c = np.abs(np.arange(N_CAM) + 0.5 - N_CAM / 2)
    inside = c < half - 1.0
    mask = inside[:, None] & inside[None, :]
    res = {"mitsuba_variant": a.variant, "spp": a.spp}
    plain = {}
    for mat in MATERIALS:
        for mp in MAPS:
            L = render_lucent(a.lucent, work, a.spp, mat, mp)
            M = render_mitsuba(a.variant, work, a.spp, mat, mp) @ LUMA
            if mp == "plain":
                plain[mat] = M
            keep = blocks(mask.astype(float)) > 0.999
            bl, bm = blocks(np.where(mask, L, 0.0))[keep], blocks(np.where(mask, M, 0.0))[keep]
            bp = blocks(np.where(mask, plain[mat], 0.0))[keep]
            r = bl / bm
            res[f"{mat}-{mp}"] = {
                "ratio": [float(x) for x in np.percentile(r, [10, 50, 90])],
                "mean_ratio": float(bl.sum() / bm.sum()),
                "mitsuba_vs_plain": [float(x) for x in np.percentile(bm / bp, [10, 50, 90])],
            }
    if a.json:
        print(json.dumps(res, indent=1))
    else:
        print(f"Mitsuba 3 {a.variant}, {a.spp} spp; luminance over 4 x 4 blocks on the square, median (10th-90th percentile):")
        for k, v in res.items():
            if isinstance(v, dict):
                r, p = v["ratio"], v["mitsuba_vs_plain"]
                print(f"  {k:18s} lucent/Mitsuba {r[1]:.4f} ({r[0]:.3f}-{r[2]:.3f}), means {v['mean_ratio']:.4f};  Mitsuba mapped/plain {p[1]:.3f} ({p[0]:.3f}-{p[2]:.3f})")


if __name__ == "__main__":
    sys.exit(main())
