#!/usr/bin/env python3
"""lucent's rough conductor, rough dielectric and smooth materials against Mitsuba 3, on spheres
lit by an environment map.

One sphere (radius 1 m, 4 m in front of a 30° pinhole camera) per material, lit by the
asymmetric map of `mitsuba_envmap.py` (turned 30° about +y), rendered with `path` (max_depth 16,
Russian roulette from depth 5 in both) in lucent and Mitsuba 3 `scalar_spectral`. For each
material the script prints the mean luminance Y over the sphere (pixels whose footprint lies on
it) in both, their ratio with its standard error (from the two renders' per-pixel spread), and
the median and 10th–90th percentile of the per-pixel ratio. Materials (lucent / Mitsuba):

* `rough_conductor`, metal "au", α = 0.2 / `roughconductor`, material "Au", GGX, α = 0.2;
* `rough_conductor`, metal "cu", α = [0.05, 0.3] is left out: both renderers align α_x with ∂p/∂u, but a
  sphere's (u, v) differ between them (`benches-peers/mitsuba_normalmap.py` compares anisotropy on a mesh);
* `rough_dielectric`, ior 1.5, α = 0.2 / `roughdielectric`, int_ior 1.5, ext_ior 1, GGX, α = 0.2;
* the same two with `distribution = "beckmann"`, α = 0.3 and `masking = "separable"` / Mitsuba's
  Beckmann (its default distribution), α = 0.3;
* `dielectric`, ior 1.5 / `dielectric`, int_ior 1.5, ext_ior 1;
* `thin_dielectric`, ior 1.5 / `thindielectric`, int_ior 1.5, ext_ior 1 (a soap-bubble sphere);
* `conductor`, metal "ag" / `conductor`, material "Ag";
* `plastic`, albedo 0.5, ior 1.5 / `plastic`, diffuse_reflectance 0.5, int_ior 1.5,
  nonlinear = true: the same model for a smooth coating (ρ (1 − F_i)(1 − F_o) / (π η² (1 − ρ F_dr)));
* `plastic` with alpha = 0.1 / `roughplastic`, GGX, α = 0.1, nonlinear = true: not quite the same
  model (lucent normalises the diffuse term by the coating's mean albedo, 1 − E_avg, so that a
  white base returns all the light; Mitsuba by 1/η²), so this row measures how far apart they are;
* the same with `distribution = "beckmann"` / `roughplastic` with Mitsuba's default Beckmann;
* the same with `coupling = "mitsuba"` (Mitsuba's diffuse term), and with α = 0.5, Beckmann and
  `nonlinear = false` / the matching `roughplastic`;
* `plastic` with nonlinear = false / `plastic` with Mitsuba's default nonlinear = false (the
  albedo is the effective albedo under the coating).

    /tmp/pyvenv/bin/python benches-peers/mitsuba_rough.py [--lucent target/release/lucent]
        [--spp 64] [--variant scalar_spectral] [--save DIR] [--json]

(All materials run in one go, about 20 s.) Needs numpy and mitsuba==3.9.1.
"""

import json
import os
import subprocess
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from mitsuba_envmap import env_map, ROTATE  # noqa: E402
from peer_common import read_pfm, write_pfm, peer_args  # noqa: E402

LUMA = np.array([0.2126, 0.7152, 0.0722])
N_CAM, FOV_DEG, Z = 64, 30.0, 4.0
MATERIALS = {
    "rough_gold": ('type = "rough_conductor"\nmetal = "au"\nalpha = 0.2',
                   {"type": "roughconductor", "material": "Au", "distribution": "ggx", "alpha": 0.2}),
    "rough_glass": ('type = "rough_dielectric"\nior = 1.5\nalpha = 0.2',
                    {"type": "roughdielectric", "int_ior": 1.5, "ext_ior": 1.0, "distribution": "ggx", "alpha": 0.2}),
    "rough_gold_beckmann": ('type = "rough_conductor"\nmetal = "au"\nalpha = 0.3\ndistribution = "beckmann"\nmasking = "separable"',
                            {"type": "roughconductor", "material": "Au", "distribution": "beckmann", "alpha": 0.3}),
    "rough_glass_beckmann": ('type = "rough_dielectric"\nior = 1.5\nalpha = 0.3\ndistribution = "beckmann"\nmasking = "separable"',
                             {"type": "roughdielectric", "int_ior": 1.5, "ext_ior": 1.0, "distribution": "beckmann", "alpha": 0.3}),
    "glass": ('type = "dielectric"\nior = 1.5', {"type": "dielectric", "int_ior": 1.5, "ext_ior": 1.0}),
    "thin_glass": ('type = "thin_dielectric"\nior = 1.5', {"type": "thindielectric", "int_ior": 1.5, "ext_ior": 1.0}),
    "silver": ('type = "conductor"\nmetal = "ag"', {"type": "conductor", "material": "Ag"}),
    "plastic": ('type = "plastic"\nalbedo = 0.5\nior = 1.5',
                {"type": "plastic", "diffuse_reflectance": {"type": "spectrum", "value": 0.5}, "int_ior": 1.5, "ext_ior": 1.0, "nonlinear": True}),
    "rough_plastic": ('type = "plastic"\nalbedo = 0.5\nior = 1.5\nalpha = 0.1',
                      {"type": "roughplastic", "distribution": "ggx", "alpha": 0.1, "diffuse_reflectance": {"type": "spectrum", "value": 0.5},
                       "int_ior": 1.5, "ext_ior": 1.0, "nonlinear": True}),
    "rough_plastic_beckmann": ('type = "plastic"\nalbedo = 0.5\nior = 1.5\nalpha = 0.1\ndistribution = "beckmann"',
                               {"type": "roughplastic", "distribution": "beckmann", "alpha": 0.1, "diffuse_reflectance": {"type": "spectrum", "value": 0.5},
                                "int_ior": 1.5, "ext_ior": 1.0, "nonlinear": True}),
    "rough_plastic_mitsuba": ('type = "plastic"\nalbedo = 0.5\nior = 1.5\nalpha = 0.1\ncoupling = "mitsuba"',
                              {"type": "roughplastic", "distribution": "ggx", "alpha": 0.1, "diffuse_reflectance": {"type": "spectrum", "value": 0.5},
                               "int_ior": 1.5, "ext_ior": 1.0, "nonlinear": True}),
    "rougher_plastic_mitsuba": ('type = "plastic"\nalbedo = 0.5\nior = 1.5\nalpha = 0.5\ndistribution = "beckmann"\ncoupling = "mitsuba"\nnonlinear = false',
                                {"type": "roughplastic", "distribution": "beckmann", "alpha": 0.5, "diffuse_reflectance": {"type": "spectrum", "value": 0.5},
                                 "int_ior": 1.5, "ext_ior": 1.0}),
    "plastic_linear": ('type = "plastic"\nalbedo = 0.5\nior = 1.5\nnonlinear = false',
                               {"type": "plastic", "diffuse_reflectance": {"type": "spectrum", "value": 0.5}, "int_ior": 1.5, "ext_ior": 1.0}),
}


def render_lucent(lucent, work, mat, spp, seed):
    axis, angle = ROTATE
    scene = f"""unit = "m"
camera = {{ eye = [0, 0, 0], look_at = [0, 0, 1], up = [0, 1, 0], vfov_deg = {FOV_DEG}, width = {N_CAM}, height = {N_CAM} }}
[integrator]
type = "path"
max_depth = 16
rr_depth = 5
[materials.m]
{MATERIALS[mat][0]}
[[objects]]
material = "m"
sphere = {{ center = [0, 0, {Z}], radius = 1 }}
[[lights]]
type = "envmap"
file = "map.pfm"
transform = {{ rotate = [{axis[0]}, {axis[1]}, {axis[2]}, {angle}] }}
"""
    path = os.path.join(work, f"lucent-{mat}.toml")
    with open(path, "w") as f:
        f.write(scene)
    out = os.path.join(work, f"lucent-{mat}-{seed}.pfm")
    subprocess.run([lucent, "render", path, "--spp", str(spp), "--seed", str(seed), "--out", out, "-q"], check=True, stdout=subprocess.DEVNULL)
    return read_pfm(out) @ LUMA


def render_mitsuba(variant, work, mat, spp, seed):
    import mitsuba as mi

    mi.set_variant(variant)
    T = mi.ScalarTransform4f
    axis, angle = ROTATE
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 16, "rr_depth": 5},
        "sensor": {
            "type": "perspective", "fov": FOV_DEG, "fov_axis": "y",
            "to_world": T().look_at(origin=[0, 0, 0], target=[0, 0, 1], up=[0, 1, 0]),
            "film": {"type": "hdrfilm", "width": N_CAM, "height": N_CAM, "pixel_format": "rgb", "rfilter": {"type": "box"}},
            "sampler": {"type": "independent", "sample_count": spp},
        },
        "ball": {"type": "sphere", "center": [0, 0, Z], "radius": 1.0, "bsdf": MATERIALS[mat][1]},
        "env": {"type": "envmap", "filename": os.path.join(work, "map.pfm"), "to_world": T().rotate(axis, angle)},
    })
    return np.array(mi.render(scene, seed=seed), dtype=np.float64) @ LUMA


def main():
    a, work, _tmp = peer_args(__doc__, 64)
    write_pfm(os.path.join(work, "map.pfm"), env_map())
    f = (N_CAM / 2) / np.tan(np.radians(FOV_DEG / 2))
    c = (np.arange(N_CAM) + 0.5 - N_CAM / 2) / f
    X, Y = np.meshgrid(c, c)
    mask = np.arctan(np.hypot(X, Y)) < np.arcsin(1.0 / Z) - 1.5 / f
    res = {"mitsuba_variant": a.variant, "spp": a.spp, "pixels": int(mask.sum()), "materials": {}}
    for mat in MATERIALS:
        l1, l2 = (render_lucent(a.lucent, work, mat, a.spp, s)[mask] for s in (1, 2))
        m1, m2 = (render_mitsuba(a.variant, work, mat, a.spp, s)[mask] for s in (1, 2))
        n = mask.sum()
        lm, mm = (l1 + l2).mean() / 2, (m1 + m2).mean() / 2
        # Standard error of each two-render mean from the per-pixel spread between its renders.
        se_l = np.sqrt(((l1 - l2) ** 2 / 2).mean() / n / 2)
        se_m = np.sqrt(((m1 - m2) ** 2 / 2).mean() / n / 2)
        ratio = lm / mm
        se_r = ratio * np.hypot(se_l / lm, se_m / mm)
        r = ((l1 + l2) / 2) / ((m1 + m2) / 2)
        res["materials"][mat] = {"lucent_Y": lm, "mitsuba_Y": mm, "ratio": ratio, "ratio_se": se_r,
                                 "pixel_ratio_p10_p50_p90": [float(x) for x in np.percentile(r, [10, 50, 90])]}
    if a.json:
        print(json.dumps(res, indent=1))
    else:
        print(f"Mitsuba 3 {a.variant}, {a.spp} spp × 2 seeds each, {res['pixels']} pixels on the sphere:")
        for mat, e in res["materials"].items():
            p = e["pixel_ratio_p10_p50_p90"]
            print(f"  {mat:12s} mean Y lucent {e['lucent_Y']:.5f}, Mitsuba {e['mitsuba_Y']:.5f}: ratio {e['ratio']:.4f} ± {e['ratio_se']:.4f}; per pixel {p[1]:.3f} ({p[0]:.3f}–{p[2]:.3f})")


if __name__ == "__main__":
    sys.exit(main())
