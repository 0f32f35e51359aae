#!/usr/bin/env python3
"""lucent's `volpath` against Mitsuba 3's `volpath`: media lit by an environment map and a spot light.

One scene (96 × 64, `volpath`, `max_depth` 64 and roulette from 5 in both): a diffuse floor
(albedo 0.4); a ball of fog (radius 0.6 m, σ_s 3 m⁻¹ below 500 nm falling to 1.5 m⁻¹ above 600 nm,
σ_a 0.3 m⁻¹, Henyey–Greenstein g = 0.4) behind an index-matched boundary (lucent `interface`,
Mitsuba `null`); a ball of the same size in smooth glass (n = 1.5) holding a back-scattering medium
(σ_s 2 m⁻¹, σ_a 0.2 m⁻¹, g = −0.3); lit by the asymmetric environment map of `mitsuba_envmap.py`
turned 30° about +y and by a spot light (intensity 6, cone 30°, linear falloff from 20°; Mitsuba's
`spot` with `cutoff_angle` 30 and `beam_width` 20). So light reaches the media by map samples,
by the delta light through an invisible and through a refracting boundary, and by BSDF and
phase samples. It prints lucent / Mitsuba in luminance over the pixels above 1 % of the maximum
(median and 10th–90th percentile, per pixel and over 4 × 4 blocks) and the ratio of the sums, and
the sums' ratio per channel of linear sRGB.

    /tmp/pyvenv/bin/python benches-peers/mitsuba_media_lights.py [--lucent target/release/lucent] [--spp 256]

Needs numpy and mitsuba==3.9.1.
"""
import os
import subprocess
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from mitsuba_envmap import env_map  # noqa: E402
from mitsuba_media import FOV, H, W, lucent_head  # noqa: E402
from peer_common import LUMA, compare_cases, peer_args, read_pfm, write_pfm  # noqa: E402

EYE, TARGET = [0.0, 1.2, -4.0], [0.0, 0.5, 0.0]
FOG_LAMBDA, FOG_SIGMA_S = [360, 500, 600, 830], [3.0, 3.0, 1.5, 1.5]
SPOT = dict(position=[0.5, 3.0, -1.0], target=[0.0, 0.0, 0.0], cone=30.0, start=20.0, intensity=6.0)


def lucent_scene():
    s = SPOT
    sig = ", ".join(f"{v / 1000}" for v in FOG_SIGMA_S)
    return lucent_head("volpath", EYE, TARGET) + f"""[materials.glass]
type = "dielectric"
ior = 1.5
[[objects]]
material = "floor"
quad = [[-5, 0, -5], [-5, 0, 5], [5, 0, 5], [5, 0, -5]]
[[objects]]
material = "matched"
sphere = {{ center = [-0.7, 0.6, 0], radius = 0.6 }}
medium = {{ sigma_a_per_mm = 0.0003, sigma_s_per_mm = {{ lambda_nm = {FOG_LAMBDA}, values = [{sig}] }}, g = 0.4 }}
[[objects]]
material = "glass"
sphere = {{ center = [0.7, 0.6, 0], radius = 0.6 }}
medium = {{ sigma_a_per_mm = 0.0002, sigma_s_per_mm = 0.002, g = -0.3 }}
[[lights]]
type = "envmap"
file = "map.pfm"
transform = {{ rotate = [0, 1, 0, 30] }}
[[lights]]
type = "spot"
position = {s['position']}
look_at = {s['target']}
cone_deg = {s['cone']}
falloff_start_deg = {s['start']}
falloff = "linear"
intensity = {s['intensity']}
"""


def run_lucent(binary, work, spp, seed):
    path = os.path.join(work, "lucent.toml")
    with open(path, "w") as f:
        f.write(lucent_scene())
    out = os.path.join(work, f"lucent-{seed}.pfm")
    subprocess.run([binary, "render", path, "--spp", str(spp), "--seed", str(seed), "--out", out, "-q"], check=True, stdout=subprocess.DEVNULL)
    return read_pfm(out)


def run_mitsuba(work, spp, variant, seed):
    import mitsuba as mi

    mi.set_variant(variant)
    T = mi.ScalarTransform4f
    lam = np.arange(360, 831)
    ss = np.interp(lam, FOG_LAMBDA, FOG_SIGMA_S)
    st = ss + 0.3
    fine = lambda v: {"type": "irregular", "wavelengths": ", ".join(map(str, lam)), "values": ", ".join(f"{x:.9g}" for x in v)}
    fog = {"type": "homogeneous", "sigma_t": fine(st), "albedo": fine(ss / st), "phase": {"type": "hg", "g": 0.4}}
    inner = {"type": "homogeneous", "sigma_t": 2.2, "albedo": 2.0 / 2.2, "phase": {"type": "hg", "g": -0.3}}
    s = SPOT
    scene = {
        "type": "scene",
        "integrator": {"type": "volpath", "max_depth": 64, "rr_depth": 5},
        "sensor": {"type": "perspective", "fov": FOV, "fov_axis": "y", "to_world": T().look_at(origin=EYE, target=TARGET, up=[0, 1, 0]),
                   "film": {"type": "hdrfilm", "width": W, "height": H, "pixel_format": "rgb", "rfilter": {"type": "box"}},
                   "sampler": {"type": "independent", "sample_count": spp}},
        # Mitsuba's rectangle faces +z: turned to face up.
        "floor": {"type": "rectangle", "to_world": T().rotate([1, 0, 0], -90) @ T().scale([5, 5, 1]),
                  "bsdf": {"type": "diffuse", "reflectance": {"type": "spectrum", "value": 0.4}}},
        "fog": {"type": "sphere", "center": [-0.7, 0.6, 0], "radius": 0.6, "bsdf": {"type": "null"}, "interior": fog},
        "glass": {"type": "sphere", "center": [0.7, 0.6, 0], "radius": 0.6, "bsdf": {"type": "dielectric", "int_ior": 1.5, "ext_ior": 1.0}, "interior": inner},
        "env": {"type": "envmap", "filename": os.path.join(work, "map.pfm"), "to_world": T().rotate([0, 1, 0], 30)},
        "spot": {"type": "spot", "to_world": T().look_at(origin=s["position"], target=s["target"], up=[0, 0, 1]),
                 "cutoff_angle": s["cone"], "beam_width": s["start"], "intensity": {"type": "spectrum", "value": s["intensity"]}},
    }
    return np.array(mi.render(mi.load_dict(scene), seed=seed), dtype=np.float64)


def main():
    a, work, _tmp = peer_args(__doc__, 256)
    write_pfm(os.path.join(work, "map.pfm"), env_map())
    images = {}

    def lucent(case):
        seed = int(case.split()[1])
        images[("lucent", seed)] = run_lucent(a.lucent, work, a.spp, seed)
        return images[("lucent", seed)] @ LUMA

    def mitsuba(case):
        seed = int(case.split()[1])
        images[("mitsuba", seed)] = run_mitsuba(work, a.spp, a.variant, seed)
        return images[("mitsuba", seed)] @ LUMA

    compare_cases(a, ("seed 1", "seed 2"), lucent, mitsuba)
    if not a.json:
        for seed in (1, 2):
            l, m = images[("lucent", seed)], images[("mitsuba", seed)]
            r = l.reshape(-1, 3).sum(0) / m.reshape(-1, 3).sum(0)
            print(f"seed {seed}: sums per channel R {r[0]:.4f}, G {r[1]:.4f}, B {r[2]:.4f}")


if __name__ == "__main__":
    main()
