#!/usr/bin/env python3
"""lucent's `volpath` against Mitsuba 3's `volpath`: media behind invisible and rough boundaries, and a sphere lamp.

Three scenes on a diffuse floor (albedo 0.4) under a constant environment of 0.2, with a
spherical area light (radius 0.3 m, radiance 10) above and in front; `volpath` in lucent, `volpath`
in Mitsuba 3 (`scalar_spectral` by default), `max_depth` 64 and roulette from 5 in both:

* `null`: a sphere (radius 0.6 m) of a Henyey–Greenstein medium (σ_s 2 m⁻¹ rising to 6 m⁻¹ from
  red to blue, σ_a 0.5 m⁻¹, g = 0.6) behind an index-matched boundary (lucent `interface`,
  Mitsuba `null`): light samples pass through the boundary and the medium attenuates them.
* `rayleigh`: the same sphere with the Rayleigh phase function (lucent `phase = "rayleigh"`,
  Mitsuba `rayleigh`).
* `rough`: the same medium in a cube of edge 1.1 m behind a rough dielectric boundary (n = 1.33,
  GGX α = 0.3; lucent `rough_dielectric`, Mitsuba `roughdielectric`).
* `spherelight`: no medium, a diffuse sphere (albedo 0.6) lit by the sphere lamp (cone sampling
  in lucent, Mitsuba's `sphere` emitter) and the environment, `path`.

All spectra are defined over 360–830 nm (Mitsuba gets σ_t and the albedo on a 1 nm grid, from
lucent's linear interpolation of σ_s; interpolating the albedo itself between the table's
wavelengths made the medium 1–2 % brighter in lucent). Expected: `null` and `spherelight` agree
per pixel within noise. In `rough` the cube is 1–4 % brighter in lucent (8 × 8 blocks, 2048 spp):
lucent's GGX uses the height-correlated Smith masking–shadowing G₂ = 1/(1 + Λ(ωo) + Λ(ωi))
(pbrt-v4; Heitz 2014), Mitsuba 3 the separable G₁(ωo)·G₁(ωi), which is darker; a throwaway lucent
build with the separable form gave 0.9988 on the clear cube against 1.014 with its own.
`rough_separable` is the same cube with `masking = "separable"` (Mitsuba's form) in lucent.
A smooth dielectric cube is left out: Mitsuba's image of a medium behind it has heavy tails
(region means 0.1115 and 0.1117 for seeds 1–2 at 1024 spp, 0.1098–0.1107 for seeds 3–6 at 2048). For each it prints lucent / Mitsuba in luminance over the
pixels above 1 % of the maximum (median and 10th–90th percentile, per pixel and over 4 × 4 blocks)
and the ratio of the image sums.

    /tmp/pyvenv/bin/python benches-peers/mitsuba_media.py [--lucent target/release/lucent] [--spp 128]

Needs numpy and mitsuba==3.9.1.
"""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from peer_common import LUMA, compare_cases, peer_args, render_luminance  # noqa: E402

W, H = 96, 64
EYE, TARGET, FOV = [0.0, 1.4, -4.0], [0.0, 0.5, 0.0], 40.0
LAMBDA = [360, 450, 550, 650, 830]
SIGMA_S_PER_M = [6.0, 6.0, 4.0, 2.0, 2.0]
SIGMA_A_PER_M, G = 0.5, 0.6
LAMP = ([1.2, 2.2, -1.0], 0.3, 10.0)


def lucent_head(integrator, eye=EYE, target=TARGET):
    """A lucent scene's camera (W × H, FOV), integrator (max_depth 64, roulette from 5) and the
    materials `floor` (diffuse, 0.4) and `matched` (an index-matched boundary)."""
    return f"""unit = "m"
camera = {{ eye = {eye}, look_at = {target}, up = [0, 1, 0], vfov_deg = {FOV}, width = {W}, height = {H} }}
[integrator]
type = "{integrator}"
max_depth = 64
rr_depth = 5
[materials.floor]
type = "lambertian"
albedo = 0.4
[materials.matched]
type = "interface"
"""


def lucent_stage(integrator):
    """The lucent scene's camera, integrator, floor, sphere lamp and environment (materials
    `floor`, `lamp`, and `matched`, an index-matched boundary)."""
    (lx, ly, lz), lr, le = LAMP
    return lucent_head(integrator) + f"""[materials.lamp]
type = "black"
[[objects]]
material = "floor"
quad = [[-5, 0, -5], [5, 0, -5], [5, 0, 5], [-5, 0, 5]]
[[objects]]
name = "lamp"
material = "lamp"
sphere = {{ center = [{lx}, {ly}, {lz}], radius = {lr} }}
[[lights]]
type = "area"
object = "lamp"
radiance = {{ rgb = [{le}, {le}, {le}] }}
[[lights]]
type = "environment"
radiance = {{ rgb = [0.2, 0.2, 0.2] }}
"""


def cube_quads(lo, hi):
    """The six outward-wound faces (counter-clockwise seen from outside) of the box lo–hi, as
    lucent's `quads`."""
    c = [[lo[0], lo[1], lo[2]], [hi[0], lo[1], lo[2]], [hi[0], hi[1], lo[2]], [lo[0], hi[1], lo[2]],
         [lo[0], lo[1], hi[2]], [hi[0], lo[1], hi[2]], [hi[0], hi[1], hi[2]], [lo[0], hi[1], hi[2]]]
    faces = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (3, 7, 6, 2), (0, 4, 7, 3), (1, 2, 6, 5)]
    return ", ".join("[" + ", ".join(str(c[i]) for i in f) + "]" for f in faces)


def lucent_scene(case):
    per_mm = [s / 1000 for s in SIGMA_S_PER_M]
    phase = 'phase = "rayleigh"' if case == "rayleigh" else f"g = {G}"
    medium = (f"medium = {{ {phase}, sigma_s_per_mm = {{ lambda_nm = {LAMBDA}, values = {per_mm} }}, "
              f"sigma_a_per_mm = {SIGMA_A_PER_M / 1000} }}")
    s = lucent_stage("path" if case == "spherelight" else "volpath") + f"""[materials.ball]
type = "lambertian"
albedo = 0.6
[materials.rough]
type = "rough_dielectric"
ior = 1.33
alpha = 0.3
{'masking = "separable"' if case == "rough_separable" else ""}
"""
    if case in ("null", "rayleigh"):
        s += f"[[objects]]\nmaterial = \"matched\"\nsphere = {{ center = [0, 0.6, 0], radius = 0.6 }}\n{medium}\n"
    elif case in ("rough", "rough_separable"):
        h = 0.55
        quads = cube_quads([-h, 0.001, -h], [h, 0.001 + 2 * h, h])
        s += f"[[objects]]\nmaterial = \"rough\"\nquads = [{quads}]\n{medium}\n"
    else:
        s += "[[objects]]\nmaterial = \"ball\"\nsphere = { center = [0, 0.6, 0], radius = 0.6 }\n"
    return s


def run_lucent(binary, work, case, spp):
    return render_luminance(binary, work, case, lucent_scene(case), spp)


def mitsuba_stage(mi, integrator, spp):
    """The Mitsuba scene dictionary of `lucent_stage` (the variant already set)."""
    T = mi.ScalarTransform4f
    (lx, ly, lz), lr, le = LAMP
    return {
        "type": "scene",
        "integrator": {"type": integrator, "max_depth": 64, "rr_depth": 5},
        "sensor": {"type": "perspective", "fov": FOV, "fov_axis": "y", "to_world": T().look_at(origin=EYE, target=TARGET, up=[0, 1, 0]),
                   "film": {"type": "hdrfilm", "width": W, "height": H, "pixel_format": "rgb", "rfilter": {"type": "box"}},
                   "sampler": {"type": "independent", "sample_count": spp}},
        "floor": {"type": "rectangle", "to_world": T().rotate([1, 0, 0], 90) @ T().scale([5, 5, 1]),
                  "bsdf": {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": {"type": "spectrum", "value": 0.4}}}},
        "lamp": {"type": "sphere", "center": [lx, ly, lz], "radius": lr,
                 "emitter": {"type": "area", "radiance": {"type": "d65", "scale": le}}},
        "env": {"type": "constant", "radiance": {"type": "d65", "scale": 0.2}},
    }


def run_mitsuba(case, spp, variant):
    import mitsuba as mi

    mi.set_variant(variant)
    T = mi.ScalarTransform4f
    scene = mitsuba_stage(mi, "path" if case == "spherelight" else "volpath", spp)
    # lucent interpolates σ_s linearly between the table's wavelengths; Mitsuba takes σ_t and the
    # albedo, which are not linear in λ between them, so both go to Mitsuba on a 1 nm grid.
    lam = np.arange(360, 831)
    sigma_s = np.interp(lam, LAMBDA, SIGMA_S_PER_M)
    sigma_t = sigma_s + SIGMA_A_PER_M
    fine = lambda v: {"type": "irregular", "wavelengths": ", ".join(map(str, lam)), "values": ", ".join(f"{x:.9g}" for x in v)}
    medium = {"type": "homogeneous", "sigma_t": fine(sigma_t), "albedo": fine(sigma_s / sigma_t),
              "scale": 1.0, "phase": {"type": "rayleigh"} if case == "rayleigh" else {"type": "hg", "g": G}}
    if case in ("null", "rayleigh"):
        scene["body"] = {"type": "sphere", "center": [0, 0.6, 0], "radius": 0.6, "bsdf": {"type": "null"}, "interior": medium}
    elif case in ("rough", "rough_separable"):
        scene["body"] = {"type": "cube", "to_world": T().translate([0, 0.551, 0]) @ T().scale(0.55),
                         "bsdf": {"type": "roughdielectric", "int_ior": 1.33, "ext_ior": 1.0, "distribution": "ggx", "alpha": 0.3},
                         "interior": medium}
    else:
        scene["body"] = {"type": "sphere", "center": [0, 0.6, 0], "radius": 0.6,
                         "bsdf": {"type": "diffuse", "reflectance": {"type": "spectrum", "value": 0.6}}}
    return np.array(mi.render(mi.load_dict(scene), seed=1), dtype=np.float64) @ np.array(LUMA)


def main():
    a, work, _tmp = peer_args(__doc__, 128)
    compare_cases(a, ("null", "rayleigh", "rough", "rough_separable", "spherelight"),
                  lambda case: run_lucent(a.lucent, work, case, a.spp), lambda case: run_mitsuba(case, a.spp, a.variant))


if __name__ == "__main__":
    main()
