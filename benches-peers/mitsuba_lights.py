#!/usr/bin/env python3
"""lucent's point and directional lights, checkerboard texture and thin-lens camera against Mitsuba 3.

Three scenes, each rendered by lucent and by Mitsuba 3 (`scalar_spectral` by default), compared
pixel by pixel in luminance (linear sRGB, D65 white: lucent `rgb = [1, 1, 1]`, Mitsuba `d65`):

* `point`: a point light of intensity 1 above a diffuse sphere (albedo 0.6) on a diffuse floor
  (albedo 0.4), `path` with `max_depth` 3 in both (direct light and one bounce).
* `directional`: the same objects under a directional light of irradiance 1 travelling along
  (1, −2, 1), the same integrator.
* `thinlens`: a floor carrying a checkerboard of 8 × 8 squares (0.1 and 0.8, Mitsuba
  `checkerboard` with `to_uv` scaled by 4), seen at a slant through a thin lens (aperture radius
  0.05 m, focus 3 m) under a constant environment of 1, `direct`; the near and far squares are
  blurred, the squares at 3 m sharp.
* `direct`: a silver mirror sphere, a rough gold sphere (GGX α 0.2) and a smooth plastic sphere
  (albedo 0.5, n 1.5, Mitsuba `nonlinear`) on a diffuse floor, lit by a one-sided 1 m × 1 m area
  light of radiance 5 overhead and a constant environment of 0.3; `direct` in both with one
  emitter and one BSDF sample (their defaults): the mirror shows the lamp and the environment only
  through its BSDF samples, the gold lobe through both techniques.

For each it prints the median and 10th–90th percentile of lucent / Mitsuba over the pixels above
1 % of the image's maximum, at full resolution and over 4 × 4 blocks (less noise). A mirrored
image, a wrong falloff or a misplaced plane of focus shows as ratios far from 1.

    /tmp/pyvenv/bin/python benches-peers/mitsuba_lights.py [--lucent target/release/lucent] [--spp 64]

Needs numpy and mitsuba==3.9.1.
"""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from peer_common import LUMA, compare_cases, peer_args, render_luminance  # noqa: E402

W, H = 96, 64
EYE, TARGET, FOV = [0.0, 1.5, -4.0], [0.0, 0.3, 0.0], 40.0
LIGHTS = {
    "point": 'type = "point"\nposition = [1.0, 3.0, -1.0]\nintensity = { rgb = [1, 1, 1] }',
    "directional": 'type = "directional"\ndirection = [1, -2, 1]\nirradiance = { rgb = [1, 1, 1] }',
}


def lucent_scene(case):
    cam = f'eye = {EYE}, look_at = {TARGET}, up = [0, 1, 0], vfov_deg = {FOV}, width = {W}, height = {H}'
    if case == "thinlens":
        cam += ", aperture_radius = 0.05, focus_distance = 3.0"
    s = f'unit = "m"\ncamera = {{ {cam} }}\n'
    if case == "direct":
        return s + """[integrator]
type = "direct"
[materials.floor]
type = "lambertian"
albedo = 0.4
[materials.silver]
type = "conductor"
metal = "ag"
[materials.gold]
type = "rough_conductor"
metal = "au"
alpha = 0.2
[materials.plastic]
type = "plastic"
albedo = 0.5
ior = 1.5
[materials.lamp]
type = "black"
[[objects]]
material = "floor"
quad = [[-5, 0, -5], [5, 0, -5], [5, 0, 5], [-5, 0, 5]]
[[objects]]
material = "silver"
sphere = { center = [-1.3, 0.6, 0], radius = 0.6 }
[[objects]]
material = "gold"
sphere = { center = [0, 0.6, 0], radius = 0.6 }
[[objects]]
material = "plastic"
sphere = { center = [1.3, 0.6, 0], radius = 0.6 }
[[objects]]
name = "lamp"
material = "lamp"
quad = [[-0.5, 3, -0.5], [0.5, 3, -0.5], [0.5, 3, 0.5], [-0.5, 3, 0.5]]
[[lights]]
type = "area"
object = "lamp"
radiance = { rgb = [5, 5, 5] }
[[lights]]
type = "environment"
radiance = { rgb = [0.3, 0.3, 0.3] }
"""
    if case == "thinlens":
        return s + """[integrator]
type = "direct"
[materials.board]
type = "lambertian"
albedo = { checkerboard = { squares = 8, even = 0.1, odd = 0.8 } }
[[objects]]
material = "board"
quad = [[-3, 0, -3], [3, 0, -3], [3, 0, 3], [-3, 0, 3]]
[[lights]]
type = "environment"
radiance = { rgb = [1, 1, 1] }
"""
    return s + f"""[integrator]
type = "path"
max_depth = 3
[materials.floor]
type = "lambertian"
albedo = 0.4
[materials.ball]
type = "lambertian"
albedo = 0.6
[[objects]]
material = "floor"
quad = [[-5, 0, -5], [5, 0, -5], [5, 0, 5], [-5, 0, 5]]
[[objects]]
material = "ball"
sphere = {{ center = [0, 0.6, 0], radius = 0.6 }}
[[lights]]
{LIGHTS[case]}
"""


def run_lucent(binary, work, case, spp):
    return render_luminance(binary, work, case, lucent_scene(case), spp)


def run_mitsuba(case, spp, variant):
    import mitsuba as mi

    mi.set_variant(variant)
    T = mi.ScalarTransform4f
    sensor = {"type": "perspective", "fov": FOV, "fov_axis": "y",
              "to_world": T().look_at(origin=EYE, target=TARGET, up=[0, 1, 0]),
              "film": {"type": "hdrfilm", "width": W, "height": H, "pixel_format": "rgb", "rfilter": {"type": "box"}},
              "sampler": {"type": "independent", "sample_count": spp}}

    def diffuse(r):
        return {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": r}}

    # Mitsuba's rectangle spans [-1, 1]² in x, y with normal +z and (u, v) = ((x + 1)/2, (y + 1)/2);
    # rotated 90° about x it lies in the x–z plane with y = 0, its local +y along world +z: the
    # same (u, v) as lucent's quad with corners (−s, 0, −s), (s, 0, −s), (s, 0, s), (−s, 0, s).
    def floor(s):
        return T().rotate([1, 0, 0], 90) @ T().scale([s, s, 1])

    if case == "direct":
        # The lamp: a rectangle at y = 3 facing down (Mitsuba's rectangle emits towards +z; a 90°
        # turn about x takes +z to −y), as lucent's quad wound to face −y.
        lamp = T().translate([0, 3, 0]) @ T().rotate([1, 0, 0], 90) @ T().scale([0.5, 0.5, 1])
        scene = {"type": "scene", "integrator": {"type": "direct"}, "sensor": sensor,
                 "floor": {"type": "rectangle", "to_world": floor(5), "bsdf": diffuse({"type": "spectrum", "value": 0.4})},
                 "silver": {"type": "sphere", "center": [-1.3, 0.6, 0], "radius": 0.6, "bsdf": {"type": "conductor", "material": "Ag"}},
                 "gold": {"type": "sphere", "center": [0, 0.6, 0], "radius": 0.6,
                          "bsdf": {"type": "roughconductor", "material": "Au", "distribution": "ggx", "alpha": 0.2}},
                 "plastic": {"type": "sphere", "center": [1.3, 0.6, 0], "radius": 0.6,
                             "bsdf": {"type": "plastic", "diffuse_reflectance": {"type": "spectrum", "value": 0.5},
                                      "int_ior": 1.5, "ext_ior": 1.0, "nonlinear": True}},
                 "lamp": {"type": "rectangle", "to_world": lamp, "bsdf": {"type": "diffuse", "reflectance": {"type": "spectrum", "value": 0.0}},
                          "emitter": {"type": "area", "radiance": {"type": "d65", "scale": 5.0}}},
                 "env": {"type": "constant", "radiance": {"type": "d65", "scale": 0.3}}}
        return np.array(mi.render(mi.load_dict(scene), seed=1), dtype=np.float64) @ np.array(LUMA)
    if case == "thinlens":
        sensor.update({"type": "thinlens", "aperture_radius": 0.05, "focus_distance": 3.0})
        # Mitsuba's focus_distance is measured along the optical axis, as lucent's.
        board = {"type": "checkerboard", "color0": {"type": "spectrum", "value": 0.1},
                 "color1": {"type": "spectrum", "value": 0.8}, "to_uv": T().scale([4, 4, 1])}
        scene = {"type": "scene", "integrator": {"type": "direct"}, "sensor": sensor,
                 "board": {"type": "rectangle", "to_world": floor(3), "bsdf": diffuse(board)},
                 "env": {"type": "constant", "radiance": {"type": "d65", "scale": 1.0}}}
    else:
        scene = {"type": "scene", "integrator": {"type": "path", "max_depth": 3}, "sensor": sensor,
                 "floor": {"type": "rectangle", "to_world": floor(5), "bsdf": diffuse({"type": "spectrum", "value": 0.4})},
                 "ball": {"type": "sphere", "center": [0, 0.6, 0], "radius": 0.6, "bsdf": diffuse({"type": "spectrum", "value": 0.6})}}
        if case == "point":
            scene["light"] = {"type": "point", "position": [1.0, 3.0, -1.0], "intensity": {"type": "d65", "scale": 1.0}}
        else:
            scene["light"] = {"type": "directional", "direction": [1, -2, 1], "irradiance": {"type": "d65", "scale": 1.0}}
    return np.array(mi.render(mi.load_dict(scene), seed=1), dtype=np.float64) @ np.array(LUMA)


def main():
    a, work, _tmp = peer_args(__doc__, 64)
    compare_cases(a, ("point", "directional", "thinlens", "direct"),
                  lambda case: run_lucent(a.lucent, work, case, a.spp), lambda case: run_mitsuba(case, a.spp, a.variant))


if __name__ == "__main__":
    main()
