#!/usr/bin/env python3
"""lucent's `disk` and `cylinder` objects against Mitsuba 3's `disk` and `cylinder` shapes.

Two scenes, each rendered by lucent and by Mitsuba 3 (`scalar_spectral` by default) with `path`
(max_depth 3: direct light and one bounce) and compared pixel by pixel in luminance (linear sRGB,
D65 white: lucent `rgb = [1, 1, 1]`, Mitsuba `d65`):

* `disk_lamp`: a diffuse floor disk (radius 2.5, albedo 0.5), a standing cylinder (open, albedo
  0.6, its inside seen through the top), a tilted cylinder (albedo 0.4) and a tilted diffuse disk
  (albedo 0.7), lit by a one-sided disk lamp of radiance 12 (radius 0.5, 1.5 m up behind the
  objects, facing down and towards the camera, which sees its emitting side) and a constant
  environment of 0.3.
* `tube_lamp`: the same floor and tilted disk lit by the standing cylinder emitting 2 on its
  outside only (as Mitsuba's area emitter on a cylinder) and an environment of 0.05; its inside,
  seen through the top, is the non-emitting back side.

Mitsuba's disk is its unit disk with `to_world = translate(c) · to_frame(Frame3f(n)) · scale(r)`,
the frame lucent uses for (u, v); its cylinder takes `p0`, `p1` and `radius` as lucent's. The
materials are `twosided` in Mitsuba, as lucent's are.

For each scene it prints the median and 10th–90th percentile of lucent / Mitsuba over the pixels
above 1 % of the image's maximum, at full resolution and over 4 × 4 blocks, and the same
statistics of each renderer against itself with another seed: the noise the first line should
show if the two agree. Then, for each object the camera sees (pixels whose centre and four
neighbours' centres see it, found by Mitsuba's ray intersection), the ratio of the mean
luminances with its standard error (from the spread between each renderer's two seeds) and the
per-pixel ratio's median and 10th–90th percentile, both seeds averaged.

    /tmp/pyvenv/bin/python benches-peers/mitsuba_shapes.py [--lucent target/release/lucent]
        [--spp 256] [--variant scalar_spectral] [--save DIR] [--json]

Needs numpy and mitsuba==3.9.1.
"""
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from peer_common import LUMA, blocks, peer_args, render_luminance, stats  # noqa: E402

W, H = 96, 72
EYE, TARGET, FOV = [0.0, 2.2, -4.5], [0.0, 0.3, 0.0], 45.0
FLOOR = ([0.0, 0.0, 0.0], [0.0, 1.0, 0.0], 2.5, 0.5)                  # centre, normal, radius, albedo
PLATE = ([1.1, 0.55, 0.6], [-0.5, 0.3, -1.0], 0.45, 0.7)
LAMP = ([0.3, 1.5, 1.2], [-0.1, -0.6, -1.0], 0.5, 12.0)                # centre, normal, radius, radiance
TUBE = ([-0.7, 0.0, 0.4], [-0.7, 1.1, 0.4], 0.35, 0.6)                 # p0, p1, radius, albedo
ROD = ([0.2, 0.25, -0.9], [1.2, 0.55, -0.3], 0.2, 0.4)
ENV = {"disk_lamp": 0.3, "tube_lamp": 0.05}
TUBE_RADIANCE = 2.0


def lucent_scene(case):
    def disk(name, d, material):
        return f'[[objects]]\nname = "{name}"\nmaterial = "{material}"\ndisk = {{ center = {d[0]}, normal = {d[1]}, radius = {d[2]} }}\n'

    def cyl(name, c, material):
        return f'[[objects]]\nname = "{name}"\nmaterial = "{material}"\ncylinder = {{ p0 = {c[0]}, p1 = {c[1]}, radius = {c[2]} }}\n'

    s = f'unit = "m"\ncamera = {{ eye = {EYE}, look_at = {TARGET}, up = [0, 1, 0], vfov_deg = {FOV}, width = {W}, height = {H} }}\n'
    s += '[integrator]\ntype = "path"\nmax_depth = 3\n'
    for name, albedo in (("floor", FLOOR[3]), ("plate", PLATE[3]), ("tube", TUBE[3]), ("rod", ROD[3])):
        s += f'[materials.{name}]\ntype = "lambertian"\nalbedo = {albedo}\n'
    s += '[materials.black]\ntype = "black"\n'
    s += disk("floor", FLOOR, "floor") + disk("plate", PLATE, "plate")
    if case == "disk_lamp":
        s += cyl("tube", TUBE, "tube") + cyl("rod", ROD, "rod") + disk("lamp", LAMP, "black")
        s += f'[[lights]]\ntype = "area"\nobject = "lamp"\nradiance = {{ rgb = [{LAMP[3]}, {LAMP[3]}, {LAMP[3]}] }}\n'
    else:
        s += cyl("tube", TUBE, "black")
        s += f'[[lights]]\ntype = "area"\nobject = "tube"\nradiance = {{ rgb = [{TUBE_RADIANCE}, {TUBE_RADIANCE}, {TUBE_RADIANCE}] }}\n'
    e = ENV[case]
    s += f'[[lights]]\ntype = "environment"\nradiance = {{ rgb = [{e}, {e}, {e}] }}\n'
    return s


def mitsuba_scene(case, spp, variant):
    import mitsuba as mi

    mi.set_variant(variant)
    T = mi.ScalarTransform4f

    def diffuse(r):
        return {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": {"type": "spectrum", "value": r}}}

    def disk(d, bsdf):
        n = np.array(d[1], dtype=float)
        frame = mi.Frame3f(mi.ScalarVector3f(*(n / np.linalg.norm(n))))
        return {"type": "disk", "to_world": T().translate(d[0]) @ T().to_frame(frame) @ T().scale(d[2]), "bsdf": bsdf}

    def cyl(c, bsdf):
        return {"type": "cylinder", "p0": c[0], "p1": c[1], "radius": c[2], "bsdf": bsdf}

    scene = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 3},
        "sensor": {"type": "perspective", "fov": FOV, "fov_axis": "y",
                   "to_world": T().look_at(origin=EYE, target=TARGET, up=[0, 1, 0]),
                   "film": {"type": "hdrfilm", "width": W, "height": H, "pixel_format": "rgb", "rfilter": {"type": "box"}},
                   "sampler": {"type": "independent", "sample_count": spp}},
        "floor": disk(FLOOR, diffuse(FLOOR[3])),
        "plate": disk(PLATE, diffuse(PLATE[3])),
        "env": {"type": "constant", "radiance": {"type": "d65", "scale": ENV[case]}},
    }
    black = diffuse(0.0)
    if case == "disk_lamp":
        scene["tube"] = cyl(TUBE, diffuse(TUBE[3]))
        scene["rod"] = cyl(ROD, diffuse(ROD[3]))
        scene["lamp"] = disk(LAMP, black)
        scene["lamp"]["emitter"] = {"type": "area", "radiance": {"type": "d65", "scale": LAMP[3]}}
    else:
        scene["tube"] = cyl(TUBE, black)
        scene["tube"]["emitter"] = {"type": "area", "radiance": {"type": "d65", "scale": TUBE_RADIANCE}}
    return mi.load_dict(scene)


def run_mitsuba(case, spp, variant, seed):
    import mitsuba as mi

    return np.array(mi.render(mitsuba_scene(case, spp, variant), seed=seed), dtype=np.float64) @ np.array(LUMA)


def object_labels(case, variant):
    """The object each pixel's centre sees (Mitsuba's shape id, "" for the background), and "" for
    pixels whose four neighbours do not all see the same object (outlines)."""
    import mitsuba as mi

    scene = mitsuba_scene(case, 1, variant)
    sensor = scene.sensors()[0]
    lab = np.full((H, W), "", dtype=object)
    for j in range(H):
        for i in range(W):
            ray, _ = sensor.sample_ray(0.0, 0.5, mi.Point2f((i + 0.5) / W, (j + 0.5) / H), mi.Point2f(0.5, 0.5))
            si = scene.ray_intersect(ray)
            lab[j, i] = si.shape.id() if si.is_valid() else ""
    inner = lab.copy()
    inner[1:-1, 1:-1][(lab[1:-1, 1:-1] != lab[:-2, 1:-1]) | (lab[1:-1, 1:-1] != lab[2:, 1:-1])
                      | (lab[1:-1, 1:-1] != lab[1:-1, :-2]) | (lab[1:-1, 1:-1] != lab[1:-1, 2:])] = ""
    inner[[0, -1], :] = ""
    inner[:, [0, -1]] = ""
    return inner


def per_object(lab, l1, l2, m1, m2):
    """For each object seen (away from its outline): the mean luminance ratio lucent / Mitsuba over
    its pixels (both seeds), its standard error from each renderer's spread between its seeds, and
    the percentiles of the per-pixel ratio."""
    out = {}
    for name in sorted(set(lab.ravel()) - {""}):
        k = lab == name
        n = int(k.sum())
        lm, mm = (l1[k] + l2[k]).mean() / 2, (m1[k] + m2[k]).mean() / 2
        se_l = np.sqrt(((l1[k] - l2[k]) ** 2 / 2).mean() / n / 2)
        se_m = np.sqrt(((m1[k] - m2[k]) ** 2 / 2).mean() / n / 2)
        # Per pixel where Mitsuba's is positive (the tube lamp's inside is black in both).
        mp = (m1[k] + m2[k]) / 2
        r = ((l1[k] + l2[k]) / 2)[mp > 0] / mp[mp > 0]
        p10, p50, p90 = np.percentile(r, [10, 50, 90]) if r.size else (np.nan,) * 3
        out[name] = {"pixels": n, "ratio": lm / mm, "ratio_se": lm / mm * float(np.hypot(se_l / lm, se_m / mm)),
                     "p10": p10, "p50": p50, "p90": p90}
    return out


def main():
    a, work, _tmp = peer_args(__doc__, 256)
    report = {"mitsuba_variant": a.variant, "spp": a.spp, "cases": {}, "objects": {}}
    for case in ENV:
        l1, l2 = (render_luminance(a.lucent, work, f"{case}-{s}", lucent_scene(case), a.spp, seed=s) for s in (1, 2))
        m1, m2 = (run_mitsuba(case, a.spp, a.variant, s) for s in (1, 2))
        pairs = {"lucent/mitsuba": (l1, m1), "lucent/lucent": (l1, l2), "mitsuba/mitsuba": (m1, m2),
                 "lucent2/mitsuba2": (l2, m2), "both seeds": ((l1 + l2) / 2, (m1 + m2) / 2)}
        report["cases"][case] = {k: {"pixels": stats(x, y), "blocks_4x4": stats(blocks(x), blocks(y))} for k, (x, y) in pairs.items()}
        report["objects"][case] = per_object(object_labels(case, a.variant), l1, l2, m1, m2)
    if a.json:
        print(json.dumps(report, indent=1))
        return
    print(f"Mitsuba 3 {a.variant}, {a.spp} spp per render, luminance ratios (median, 10th–90th percentile):")
    for case, r in report["cases"].items():
        print(case)
        for k, e in r.items():
            p, b = e["pixels"], e["blocks_4x4"]
            print(f"  {k:16s} pixels {p['median']:.4f} ({p['p10']:.4f}–{p['p90']:.4f}), "
                  f"4×4 blocks {b['median']:.4f} ({b['p10']:.4f}–{b['p90']:.4f}), sum ratio {p['mean_ratio']:.4f} over {p['pixels']} pixels")
        for name, o in report["objects"][case].items():
            print(f"  {name:16s} mean Y lucent / Mitsuba {o['ratio']:.4f} ± {o['ratio_se']:.4f} over {o['pixels']} pixels; "
                  f"per pixel {o['p50']:.4f} ({o['p10']:.4f}–{o['p90']:.4f})")


if __name__ == "__main__":
    sys.exit(main())
