#!/usr/bin/env python3
"""lucent's `envmap` light against Mitsuba 3's `envmap` emitter, pixel by pixel.

lucent places a latitude–longitude image around the scene as Mitsuba 3 does (docs/scene-format.md,
"Environment maps"). This script checks it by rendering, in both renderers, what a camera at the
origin sees of one map in five directions (+z, +x, −x, −z and straight up), with the map
rotated by the same `transform` / `to_world`, and a diffuse sphere lit by the map alone (the
map's sampling and its scale). It prints, per view, the ratio lucent / Mitsuba of the luminance
Y and of each sRGB channel: the median and the 10th–90th percentiles over the pixels. A map
turned, mirrored or shifted by a texel would put the ratios far from 1 in some view.

The map is 64 × 32 texels of smooth colour (R rising with u, G with v, B with both), times 4 in
one 8 × 6-texel block, so that any flip or turn of the image shows. Both renderers carry it as
linear sRGB uplifted to spectra with a D65 white (Mitsuba: `scalar_spectral`; PFM input).
Mitsuba filters the map bilinearly in RGB and uplifts the result; lucent interpolates the
texels' spectra. The two differ only inside a texel, by much less than the tolerance a flip
would break.

    /tmp/pyvenv/bin/python benches-peers/mitsuba_envmap.py [--lucent target/release/lucent]
        [--spp 16] [--variant scalar_spectral] [--save DIR] [--json]

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
W_MAP, H_MAP, N_CAM, FOV_DEG = 64, 32, 48, 60.0
ROTATE = ([0.0, 1.0, 0.0], 30.0)  # the map's transform: 30° about +y
# (name, look direction, up): the views of the map, and the sphere's view.
VIEWS = [("+z", [0, 0, 1], [0, 1, 0]), ("+x", [1, 0, 0], [0, 1, 0]), ("-x", [-1, 0, 0], [0, 1, 0]),
         ("-z", [0, 0, -1], [0, 1, 0]), ("up", [0, 1, 0], [0, 0, 1])]
SPHERE = ([0.0, 0.0, 4.0], 1.0)


def env_map():
    u = (np.arange(W_MAP) + 0.5) / W_MAP
    v = (np.arange(H_MAP) + 0.5) / H_MAP
    U, V = np.meshgrid(u, v)
    img = np.stack([0.2 + 0.6 * U, 0.2 + 0.6 * V, 0.2 + 0.3 * U * V + 0.3 * (1 - V)], axis=2)
    img[5:11, 40:48] *= 4.0
    return img


def render_lucent(lucent, work, spp):
    out = {}
    axis, angle = ROTATE
    for name, d, up in VIEWS + [("sphere", [0, 0, 1], [0, 1, 0])]:
        # The sphere view sees the sphere; the others look away from it at a tiny sphere
        # below (lucent needs an object), which none of the five views sees.
        obj = (f"sphere = {{ center = {SPHERE[0]}, radius = {SPHERE[1]} }}" if name == "sphere"
               else "sphere = { center = [0, -100, 0], radius = 0.001 }")
        scene = f"""unit = "m"
camera = {{ eye = [0, 0, 0], look_at = {d}, up = {up}, vfov_deg = {FOV_DEG}, width = {N_CAM}, height = {N_CAM} }}
[integrator]
type = "path"
max_depth = 2
[materials.grey]
type = "lambertian"
albedo = 0.5
[[objects]]
material = "grey"
{obj}
[[lights]]
type = "envmap"
file = "map.pfm"
transform = {{ rotate = [{axis[0]}, {axis[1]}, {axis[2]}, {angle}] }}
"""
        path = os.path.join(work, f"lucent-{name}.toml")
        with open(path, "w") as f:
            f.write(scene)
        pfm = os.path.join(work, f"lucent-{name}.pfm")
        subprocess.run([lucent, "render", path, "--spp", str(spp), "--seed", "1", "--out", pfm, "-q"], check=True, stdout=subprocess.DEVNULL)
        out[name] = read_pfm(pfm)
    return out


def render_mitsuba(variant, work, spp):
    import mitsuba as mi

    mi.set_variant(variant)
    T = mi.ScalarTransform4f
    axis, angle = ROTATE
    out = {}
    for name, d, up in VIEWS + [("sphere", [0, 0, 1], [0, 1, 0])]:
        scene = {
            "type": "scene",
            "integrator": {"type": "path", "max_depth": 2},
            "sensor": {
                "type": "perspective", "fov": FOV_DEG, "fov_axis": "y",
                "to_world": T().look_at(origin=[0, 0, 0], target=d, up=up),
                "film": {"type": "hdrfilm", "width": N_CAM, "height": N_CAM, "pixel_format": "rgb", "rfilter": {"type": "box"}},
                "sampler": {"type": "independent", "sample_count": spp},
            },
            "env": {"type": "envmap", "filename": os.path.join(work, "map.pfm"), "to_world": T().rotate(axis, angle)},
        }
        if name == "sphere":
            scene["ball"] = {"type": "sphere", "center": SPHERE[0], "radius": SPHERE[1],
                             "bsdf": {"type": "diffuse", "reflectance": {"type": "spectrum", "value": 0.5}}}
        out[name] = np.array(mi.render(mi.load_dict(scene), seed=1), dtype=np.float64)
    return out


def main():
    a, work, _tmp = peer_args(__doc__, 16)
    write_pfm(os.path.join(work, "map.pfm"), env_map())
    luc = render_lucent(a.lucent, work, a.spp)
    mts = render_mitsuba(a.variant, work, a.spp)
    res = {"mitsuba_variant": a.variant, "spp": a.spp, "views": {}}
    # The sphere's pixels: those whose ray meets it (from the camera geometry).
    f = (N_CAM / 2) / np.tan(np.radians(FOV_DEG / 2))
    c = (np.arange(N_CAM) + 0.5 - N_CAM / 2) / f
    X, Y = np.meshgrid(c, c)
    # Angle of a pixel's ray from the axis; the sphere subtends asin(r / d), minus a pixel.
    ang = np.arctan(np.hypot(X, Y))
    on_sphere = ang < np.arcsin(SPHERE[1] / SPHERE[0][2]) - 1.5 / f
    for name in luc:
        L, M = luc[name], mts[name]
        mask = on_sphere if name == "sphere" else np.ones(L.shape[:2], bool)
        entry = {}
        for k, (label, w) in enumerate([("R", np.eye(3)[0]), ("G", np.eye(3)[1]), ("B", np.eye(3)[2]), ("Y", LUMA)]):
            r = (L @ w)[mask] / (M @ w)[mask]
            entry[label] = [float(x) for x in np.percentile(r, [10, 50, 90])]
        res["views"][name] = entry
    if a.json:
        print(json.dumps(res, indent=1))
    else:
        print(f"Mitsuba 3 {a.variant}, {a.spp} spp; lucent / Mitsuba, median (10th–90th percentile) over the pixels:")
        for name, e in res["views"].items():
            print(f"  {name:6s} " + "  ".join(f"{c} {m[1]:.4f} ({m[0]:.3f}–{m[2]:.3f})" for c, m in e.items()))


if __name__ == "__main__":
    sys.exit(main())
