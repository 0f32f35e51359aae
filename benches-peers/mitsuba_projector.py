#!/usr/bin/env python3
"""lucent's `projector` light against Mitsuba 3's `projector` emitter, pixel by pixel.

Mitsuba 3 reads the projected image as the irradiance on the virtual image plane at unit
distance: its emitter's intensity towards a point at angle θ off the optical axis is
π · E · scale / cos³θ (`src/emitters/projector.cpp`). lucent's `profile = "irradiance"` is that
model; its default `profile = "intensity"` (pbrt-v4's) has intensity v · I₀ in every direction,
i.e. cos³θ / π times Mitsuba's. This script renders the same scene in both renderers and prints,
for each lucent profile, the ratio lucent / Mitsuba of the luminance Y over the lit pixels: its
median and its spread (10th and 90th percentiles). The irradiance profile should give 1 and 1
everywhere; the intensity profile the median of cos³θ / π with a spread across the image.

Scene: a 64 × 64 pinhole camera and the projector at the origin, both looking along +z with +y
up and a 50° field of view (square images, so fov_axis does not matter); a Lambertian plane of
albedo 0.5 through (0, 0, 2), tilted 30° about the x axis; the projector's 32 × 32 float image
(PFM, linear) is a ramp across x with a bright block in one corner, so that a flip of either
image axis would show. White is the equal-energy spectrum in both: Mitsuba's spectral variants
uplift the bitmap's RGB (no D65 factor, unlike a plain emitter colour; a grey pixel v is the
constant spectrum v), and lucent gets `intensity = 1`. (With `intensity = { rgb = [1, 1, 1] }`,
D65 of luminance 1, lucent's white is D65, as pbrt-v4's: the same luminance, another colour.) Both use the `direct` integrator
(one light sample, delta light) and a box pixel filter; Mitsuba's bitmap uses nearest lookup, as
lucent's projector does.

The pattern stays within [0, 1]: Mitsuba's spectral variants clamp a bitmap's values to 1 there
(a block of 1.5 renders 1.5× brighter in lucent than in Mitsuba), lucent does not.

A third scene puts a ball of fog (σ_s 2 m⁻¹, σ_a 0.5 m⁻¹, Henyey–Greenstein g = 0.5, index-matched)
in the projector's beam before a diffuse wall and looks from beside the projector (`volpath`,
max_depth 64, roulette from 5 in both), and prints lucent / Mitsuba summed over the wall the
projector lights directly and over the pixels only the fog's light reaches (the beam in the fog,
the wall it lights around the projected image).

A second image in colour (red rising across x, green down y, a blue block) is projected in the
irradiance profile too, and the ratio is printed per channel of linear sRGB. Mitsuba uplifts each
pixel's RGB (components clamped to [0, 1]) to the bounded reflectance spectrum, lucent to 2·max(rgb)
times that of rgb/(2·max) (as its emitting textures; components above 1 allowed): spectra of the
same colour under D65, whose colours without D65 may differ a little.

    /tmp/pyvenv/bin/python benches-peers/mitsuba_projector.py [--lucent target/release/lucent]
        [--spp 64] [--variant scalar_spectral] [--save DIR] [--json]

Needs numpy and mitsuba==3.9.1.
"""

import json
import os
import subprocess
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from peer_common import ROOT, read_pfm, write_pfm, peer_args  # noqa: E402

LUMA = np.array([0.2126, 0.7152, 0.0722])
N_CAM, N_PROJ, FOV_DEG, ALBEDO, TILT_DEG, DIST = 64, 32, 50.0, 0.5, 30.0, 2.0


def pattern():
    x = (np.arange(N_PROJ) + 0.5) / N_PROJ
    v = np.tile(0.2 + 0.8 * x, (N_PROJ, 1))
    v[2:10, 2:10] = 1.0
    return np.repeat(v[:, :, None], 3, axis=2)


def colour_pattern():
    x = (np.arange(N_PROJ) + 0.5) / N_PROJ
    v = np.zeros((N_PROJ, N_PROJ, 3))
    v[:, :, 0] = 0.1 + 0.9 * x[None, :]
    v[:, :, 1] = 0.1 + 0.8 * x[:, None]
    v[:, :, 2] = 0.2
    v[2:10, 20:28] = [0.1, 0.2, 1.0]
    return v


def plane_corners():
    """A 4 m square through (0, 0, DIST), tilted TILT_DEG about the x axis."""
    s, c = np.sin(np.radians(TILT_DEG)), np.cos(np.radians(TILT_DEG))
    return [[u, v * c, DIST + v * s] for u, v in [(-2, -2), (2, -2), (2, 2), (-2, 2)]]


def render_lucent(lucent, work, profile, spp, image="pattern.pfm"):
    q = ", ".join("[%g, %g, %g]" % tuple(p) for p in plane_corners())
    cam = f"eye = [0, 0, 0], look_at = [0, 0, 1], up = [0, 1, 0], vfov_deg = {FOV_DEG}"
    scene = f"""unit = "m"
camera = {{ {cam}, width = {N_CAM}, height = {N_CAM} }}
[integrator]
type = "direct"
[materials.plane]
type = "lambertian"
albedo = {ALBEDO}
[[objects]]
material = "plane"
quad = [{q}]
[[lights]]
type = "projector"
image = "{image}"
response = "linear"
profile = "{profile}"
intensity = 1
camera = {{ {cam} }}
"""
    path = os.path.join(work, f"lucent-{profile}-{image}.toml")
    with open(path, "w") as f:
        f.write(scene)
    out = os.path.join(work, f"lucent-{profile}-{image}.pfm")
    subprocess.run([lucent, "render", path, "--spp", str(spp), "--seed", "1", "--out", out, "-q"], check=True, stdout=subprocess.DEVNULL)
    return read_pfm(out)


def render_mitsuba(variant, work, spp, image="pattern.pfm"):
    import mitsuba as mi

    mi.set_variant(variant)
    T = mi.ScalarTransform4f
    look = T().look_at(origin=[0, 0, 0], target=[0, 0, 1], up=[0, 1, 0])
    corners = np.array(plane_corners())
    centre = corners.mean(0)
    # Mitsuba's `rectangle` spans [-1, 1]² in z = 0: scale, tilt about x, move to the centre.
    to_world = T().translate(centre.tolist()) @ T().rotate([1, 0, 0], TILT_DEG) @ T().scale([2, 2, 1])
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "direct", "emitter_samples": 1, "bsdf_samples": 0},
        "sensor": {
            "type": "perspective", "fov": FOV_DEG, "to_world": look,
            "film": {"type": "hdrfilm", "width": N_CAM, "height": N_CAM, "pixel_format": "rgb", "rfilter": {"type": "box"}},
            "sampler": {"type": "independent", "sample_count": spp},
        },
        "plane": {"type": "rectangle", "to_world": to_world, "flip_normals": False,
                  "bsdf": {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": {"type": "spectrum", "value": ALBEDO}}}},
        "projector": {"type": "projector", "fov": FOV_DEG, "to_world": look, "scale": 1.0,
                      "irradiance": {"type": "bitmap", "filename": os.path.join(work, image), "filter_type": "nearest"}},
    })
    img = np.array(mi.render(scene, seed=1), dtype=np.float64)
    return img


FOG_CAM = dict(eye=[0.8, 0.3, 0], look_at=[0, 0, 2], up=[0, 1, 0], fov=45.0, n=64)


def fog_lucent(lucent, work, spp, fog=True):
    c = FOG_CAM
    sig = "sigma_a_per_mm = 0.0005, sigma_s_per_mm = 0.002" if fog else "sigma_a_per_mm = 0, sigma_s_per_mm = 0"
    scene = f"""unit = "m"
camera = {{ eye = {c['eye']}, look_at = {c['look_at']}, up = {c['up']}, vfov_deg = {c['fov']}, width = {c['n']}, height = {c['n']} }}
[integrator]
type = "volpath"
max_depth = 64
rr_depth = 5
[materials.wall]
type = "lambertian"
albedo = 0.5
[materials.matched]
type = "interface"
[[objects]]
material = "wall"
quad = [[-4, -4, 3], [4, -4, 3], [4, 4, 3], [-4, 4, 3]]
[[objects]]
material = "matched"
sphere = {{ center = [0, 0, 1.5], radius = 0.5 }}
medium = {{ {sig}, g = 0.5 }}
[[lights]]
type = "projector"
image = "pattern.pfm"
response = "linear"
profile = "irradiance"
intensity = 1
camera = {{ eye = [0, 0, 0], look_at = [0, 0, 1], up = [0, 1, 0], vfov_deg = {FOV_DEG} }}
"""
    name = "fog" if fog else "nofog"
    path = os.path.join(work, f"lucent-{name}.toml")
    with open(path, "w") as f:
        f.write(scene)
    out = os.path.join(work, f"lucent-{name}.pfm")
    subprocess.run([lucent, "render", path, "--spp", str(spp), "--seed", "1", "--out", out, "-q"], check=True, stdout=subprocess.DEVNULL)
    return read_pfm(out) @ LUMA


def fog_mitsuba(variant, work, spp):
    import mitsuba as mi

    mi.set_variant(variant)
    T = mi.ScalarTransform4f
    c = FOG_CAM
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "volpath", "max_depth": 64, "rr_depth": 5},
        "sensor": {"type": "perspective", "fov": c["fov"], "fov_axis": "y", "to_world": T().look_at(origin=c["eye"], target=c["look_at"], up=c["up"]),
                   "film": {"type": "hdrfilm", "width": c["n"], "height": c["n"], "pixel_format": "rgb", "rfilter": {"type": "box"}},
                   "sampler": {"type": "independent", "sample_count": spp}},
        # Mitsuba's rectangle faces +z: turned to face the projector.
        "wall": {"type": "rectangle", "to_world": T().translate([0, 0, 3]) @ T().scale([4, 4, 1]) @ T().rotate([0, 1, 0], 180),
                 "bsdf": {"type": "diffuse", "reflectance": {"type": "spectrum", "value": 0.5}}},
        "ball": {"type": "sphere", "center": [0, 0, 1.5], "radius": 0.5, "bsdf": {"type": "null"},
                 "interior": {"type": "homogeneous", "sigma_t": 2.5, "albedo": 0.8, "phase": {"type": "hg", "g": 0.5}}},
        "projector": {"type": "projector", "fov": FOV_DEG, "to_world": T().look_at(origin=[0, 0, 0], target=[0, 0, 1], up=[0, 1, 0]), "scale": 1.0,
                      "irradiance": {"type": "bitmap", "filename": os.path.join(work, "pattern.pfm"), "filter_type": "nearest"}},
    })
    return np.array(mi.render(scene, seed=1), dtype=np.float64) @ LUMA


def main():
    a, work, _tmp = peer_args(__doc__, 64)
    write_pfm(os.path.join(work, "pattern.pfm"), pattern())
    mts = render_mitsuba(a.variant, work, a.spp)
    y_m = mts @ LUMA
    lit = y_m > 0.05 * y_m.max()
    res = {"mitsuba_variant": a.variant, "spp": a.spp, "lit_px": int(lit.sum()), "profiles": {}}
    # cos³θ / π at each camera pixel centre (camera and projector share the model).
    f = (N_CAM / 2) / np.tan(np.radians(FOV_DEG / 2))
    c = (np.arange(N_CAM) + 0.5 - N_CAM / 2) / f
    cos3 = (1 + c[None, :] ** 2 + c[:, None] ** 2) ** -1.5
    for profile in ("irradiance", "intensity"):
        y_l = render_lucent(a.lucent, work, profile, a.spp) @ LUMA
        r = y_l[lit] / y_m[lit]
        p10, p50, p90 = np.percentile(r, [10, 50, 90])
        entry = {"ratio_p10": p10, "ratio_median": p50, "ratio_p90": p90}
        if profile == "intensity":
            entry["ratio_over_cos3_per_pi_median"] = float(np.median(r / (cos3[lit] / np.pi)))
        res["profiles"][profile] = entry
    write_pfm(os.path.join(work, "colours.pfm"), colour_pattern())
    lc = render_lucent(a.lucent, work, "irradiance", a.spp, "colours.pfm")
    mc = render_mitsuba(a.variant, work, a.spp, "colours.pfm")
    lit_c = (mc @ LUMA) > 0.05 * (mc @ LUMA).max()
    res["colour"] = {}
    for k, name in enumerate("RGB"):
        r = lc[..., k][lit_c] / mc[..., k][lit_c]
        p10, p50, p90 = np.percentile(r, [10, 50, 90])
        res["colour"][name] = {"ratio_p10": p10, "ratio_median": p50, "ratio_p90": p90,
                               "sum_ratio": float(lc[..., k][lit_c].sum() / mc[..., k][lit_c].sum())}
    l_fog, m_fog = fog_lucent(a.lucent, work, 4 * a.spp), fog_mitsuba(a.variant, work, 4 * a.spp)
    direct = fog_lucent(a.lucent, work, 16, fog=False) > 0
    through_fog = ~direct & (m_fog > 0)
    res["fog"] = {"spp": 4 * a.spp, "direct_sum_ratio": float(l_fog[direct].sum() / m_fog[direct].sum()),
                  "fog_only_sum_ratio": float(l_fog[through_fog].sum() / m_fog[through_fog].sum()),
                  "direct_px": int(direct.sum()), "fog_only_px": int(through_fog.sum())}
    if a.json:
        print(json.dumps(res, indent=1))
    else:
        print(f"Mitsuba 3 {a.variant}, {a.spp} spp, {res['lit_px']} lit pixels; lucent / Mitsuba luminance:")
        for p, e in res["profiles"].items():
            extra = f"; divided by cos³θ/π: median {e['ratio_over_cos3_per_pi_median']:.4f}" if "ratio_over_cos3_per_pi_median" in e else ""
            print(f"  profile = {p}: median {e['ratio_median']:.4f} (10th–90th percentile {e['ratio_p10']:.4f}–{e['ratio_p90']:.4f}){extra}")
        f = res["fog"]
        print(f"  fog ball in the beam, volpath, {f['spp']} spp: wall lit directly {f['direct_sum_ratio']:.4f} ({f['direct_px']} px), "
              f"lit only through the fog {f['fog_only_sum_ratio']:.4f} ({f['fog_only_px']} px)")
        for name, e in res["colour"].items():
            print(f"  colour image, irradiance profile, {name}: median {e['ratio_median']:.4f} "
                  f"(10th–90th percentile {e['ratio_p10']:.4f}–{e['ratio_p90']:.4f}), sums {e['sum_ratio']:.4f}")


if __name__ == "__main__":
    sys.exit(main())
