#!/usr/bin/env python3
"""lucent's `volpath` in a density grid against Mitsuba 3's `volpath` in its `heterogeneous` medium.

One grid of 16 × 16 × 16 densities (a Gaussian blob, a hollow and a ramp, written once as a
Mitsuba .vol file and read by both renderers) fills the bounding box of a body on a diffuse floor
(albedo 0.4) under a constant environment of 0.2 and a spherical area light (radius 0.3 m,
radiance 10) above and in front, as in `mitsuba_media.py`. Extinction σ_t = 2.5 m⁻¹ × density at
every wavelength (Mitsuba's `heterogeneous` takes one σ_t volume and a scale), single-scattering
albedo 0.9 below 450 nm falling to 0.5 above 650 nm (a spectrum in both), Henyey–Greenstein
g = 0.5; `max_depth` 64 and roulette from 5 in both.

* `sphere`: a sphere (radius 0.6 m) behind an index-matched boundary (lucent `interface`,
  Mitsuba `null`); the grid's box is the sphere's bounding box.
* `cube`: the same grid in a cube of edge 1.2 m, its box the cube.
* `albedo`: the sphere with a grey medium (σ_s = σ_t at density 1) and a second grid of the same
  size for the single-scattering albedo, 0.95 at the bottom falling to 0.25 at the top with a
  dark ball (lucent's `density.albedo`, Mitsuba's `albedo` as a `gridvolume`).
* `rgb`: the `albedo` case with a colour per cell instead (a three-channel grid: orange at the
  bottom turning blue at the top, a green ball inside); ratios per channel of linear sRGB.
  lucent uplifts each cell's colour to a bounded reflectance spectrum, Mitsuba's spectral
  variants to 2·max(rgb) times the sigmoid of rgb/(2·max), interpolated as spectrum and scale
  apart: the same colour per cell, other spectra.

lucent integrates the trilinear density exactly along rays (`medium::grid`), Mitsuba tracks it with
null collisions against a majorant; both interpolate trilinearly between cell centres and clamp
outside. For each case it prints lucent / Mitsuba in luminance over the pixels where the medium
changes the image by more than 5 % (against a lucent render with the density scaled to 0): median
and 10th–90th percentile per pixel and over the 4 × 4 blocks wholly in that mask, and the ratio
of the sums over the mask.

    /tmp/pyvenv/bin/python benches-peers/mitsuba_heterogeneous.py [--lucent target/release/lucent] [--spp 256]

With EFFICIENCY=1 in the environment it also renders the sphere twice more with each renderer (seeds
1 and 2, Mitsuba after an untimed 1-spp render) and prints each one's per-pixel noise over the
medium, CPU seconds per render (lucent: the child process, scene loading included; Mitsuba: the
Python process) and efficiency 1/(noise² · CPU-s).

Needs numpy and mitsuba==3.9.1.
"""
import json
import os
import resource
import struct
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from mitsuba_media import cube_quads, lucent_stage, mitsuba_stage  # noqa: E402
from peer_common import LUMA, blocks, peer_args, render_luminance, render_rgb  # noqa: E402

LAMBDA = [360, 450, 550, 650, 830]
ALBEDO = [0.9, 0.9, 0.7, 0.5, 0.5]
SIGMA_T_PER_M, G = 2.5, 0.5
N = 16


def density():
    """Densities at the cell centres of the unit cube, indexed [z, y, x] (x fastest when flattened)."""
    c = (np.arange(N) + 0.5) / N
    z, y, x = np.meshgrid(c, c, c, indexing="ij")
    blob = 3.0 * np.exp(-((x - 0.35) ** 2 + (y - 0.6) ** 2 + (z - 0.4) ** 2) / (2 * 0.18 ** 2))
    hollow = np.where((x - 0.7) ** 2 + (y - 0.35) ** 2 + (z - 0.6) ** 2 < 0.2 ** 2, 0.0, 1.0)
    return (blob + (0.3 + 0.9 * x) * hollow).astype(np.float32)


def write_vol(path, d, lo, hi):
    channels = 3 if d.ndim == 4 else 1
    with open(path, "wb") as f:
        f.write(b"VOL" + bytes([3]))
        f.write(struct.pack("<5i", 1, N, N, N, channels))
        f.write(struct.pack("<6f", *lo, *hi))
        f.write(np.ascontiguousarray(d, dtype="<f4").tobytes())


def albedo_grid():
    """Single-scattering albedo at the cell centres, indexed [z, y, x]."""
    c = (np.arange(N) + 0.5) / N
    z, y, x = np.meshgrid(c, c, c, indexing="ij")
    ball = (x - 0.5) ** 2 + (y - 0.5) ** 2 + (z - 0.3) ** 2 < 0.22 ** 2
    return np.where(ball, 0.3, 0.95 - 0.7 * y).astype(np.float32)


def rgb_albedo_grid():
    """Linear sRGB albedo at the cell centres, indexed [z, y, x, channel]."""
    c = (np.arange(N) + 0.5) / N
    z, y, x = np.meshgrid(c, c, c, indexing="ij")
    bottom, top, green = np.array([0.9, 0.55, 0.25]), np.array([0.3, 0.5, 0.85]), np.array([0.35, 0.8, 0.35])
    rgb = bottom + (top - bottom) * y[..., None]
    ball = (x - 0.5) ** 2 + (y - 0.5) ** 2 + (z - 0.3) ** 2 < 0.22 ** 2
    return np.where(ball[..., None], green, rgb).astype(np.float32)


def body_box(case):
    if case == "sphere":
        return [-0.6, 0.0, -0.6], [0.6, 1.2, 0.6]
    return [-0.6, 0.001, -0.6], [0.6, 1.201, 0.6]


def lucent_scene(case, vol, scale=1.0, albedo_vol=None):
    albedo = [1.0] * len(ALBEDO) if albedo_vol else ALBEDO
    sigma_s = [a * SIGMA_T_PER_M / 1000 for a in albedo]
    sigma_a = [(1 - a) * SIGMA_T_PER_M / 1000 for a in albedo]
    lo, hi = body_box(case)
    albedo_key = f", albedo = {{ file = \"{albedo_vol}\", min = {lo}, max = {hi} }}" if albedo_vol else ""
    medium = (f"medium = {{ g = {G}, sigma_s_per_mm = {{ lambda_nm = {LAMBDA}, values = {sigma_s} }}, "
              f"sigma_a_per_mm = {{ lambda_nm = {LAMBDA}, values = {sigma_a} }}, "
              f"density = {{ file = \"{vol}\", min = {lo}, max = {hi}, scale = {scale}{albedo_key} }} }}")
    body = "sphere = { center = [0, 0.6, 0], radius = 0.6 }" if case != "cube" else f"quads = [{cube_quads(lo, hi)}]"
    return lucent_stage("volpath") + f"[[objects]]\nmaterial = \"matched\"\n{body}\n{medium}\n"


def run_mitsuba(case, spp, variant, vol, seed=1, albedo_vol=None):
    import mitsuba as mi

    mi.set_variant(variant)
    T = mi.ScalarTransform4f
    scene = mitsuba_stage(mi, "volpath", spp)
    lo, hi = body_box(case)
    lam = np.arange(360, 831)
    albedo = np.interp(lam, LAMBDA, ALBEDO)
    fine = {"type": "irregular", "wavelengths": ", ".join(map(str, lam)), "values": ", ".join(f"{x:.9g}" for x in albedo)}
    size = [h - l for l, h in zip(lo, hi)]
    medium = {"type": "heterogeneous", "albedo": fine, "scale": SIGMA_T_PER_M, "phase": {"type": "hg", "g": G},
              "sigma_t": {"type": "gridvolume", "filename": vol, "to_world": T().translate(lo) @ T().scale(size)}}
    if albedo_vol:
        medium["albedo"] = {"type": "gridvolume", "filename": albedo_vol, "to_world": T().translate(lo) @ T().scale(size)}
    if case != "cube":
        scene["body"] = {"type": "sphere", "center": [0, 0.6, 0], "radius": 0.6, "bsdf": {"type": "null"}, "interior": medium}
    else:
        centre = [(l + h) / 2 for l, h in zip(lo, hi)]
        scene["body"] = {"type": "cube", "to_world": T().translate(centre) @ T().scale([s / 2 for s in size]),
                         "bsdf": {"type": "null"}, "interior": medium}
    return np.array(mi.render(mi.load_dict(scene), seed=seed), dtype=np.float64)


def ratios(l, m):
    r = l / m
    p10, p50, p90 = np.percentile(r, [10, 50, 90])
    return {"median": p50, "p10": p10, "p90": p90, "count": int(r.size)}


def cpu(who):
    r = resource.getrusage(who)
    return r.ru_utime + r.ru_stime


def efficiency(a, work, vol, mask):
    """Per-pixel noise over `mask` and CPU seconds of two renders (seeds 1 and 2) by each renderer
    at --spp (Mitsuba after an untimed 1-spp render that compiles its kernels), and the efficiency
    1/(noise² · CPU-s) of one render."""
    out = {}
    runs = {"lucent": lambda seed: render_luminance(a.lucent, work, "sphere", lucent_scene("sphere", vol), a.spp, seed),
            "mitsuba": lambda seed: run_mitsuba("sphere", a.spp, a.variant, vol, seed) @ np.array(LUMA)}
    run_mitsuba("sphere", 1, a.variant, vol)
    for name, run in runs.items():
        who = resource.RUSAGE_CHILDREN if name == "lucent" else resource.RUSAGE_SELF
        images, seconds = [], []
        for seed in (1, 2):
            c0 = cpu(who)
            images.append(run(seed))
            seconds.append(cpu(who) - c0)
        x, y = images[0][mask], images[1][mask]
        noise = np.sqrt(np.mean((x - y) ** 2) / 2) / np.mean((x + y) / 2)
        t = float(np.mean(seconds))
        out[name] = {"noise": float(noise), "cpu_s": t, "efficiency": 1.0 / (noise ** 2 * t), "mean_y": float(np.mean((x + y) / 2))}
    return out


def main():
    a, work, _tmp = peer_args(__doc__, 256)
    d = density()
    report = {}
    for case in ("sphere", "cube", "albedo", "rgb"):
        lo, hi = body_box(case)
        vol = os.path.join(work, f"{case}.vol")
        write_vol(vol, d, lo, hi)
        avol = None
        if case == "albedo":
            avol = os.path.join(work, "albedo-grid.vol")
            write_vol(avol, albedo_grid(), lo, hi)
        elif case == "rgb":
            avol = os.path.join(work, "rgb-albedo-grid.vol")
            write_vol(avol, rgb_albedo_grid(), lo, hi)
        lrgb = render_rgb(a.lucent, work, case, lucent_scene(case, vol, albedo_vol=avol), a.spp)
        l0 = render_luminance(a.lucent, work, case + "-empty", lucent_scene(case, vol, 0.0, avol), 64)
        mrgb = run_mitsuba(case, a.spp, a.variant, vol, albedo_vol=avol)
        l, m = lrgb @ np.array(LUMA), mrgb @ np.array(LUMA)
        mask = np.abs(m - l0) > 0.05 * l0
        bm = blocks(mask.astype(float)) == 1.0
        report[case] = {"pixels": ratios(l[mask], m[mask]), "blocks_4x4": ratios(blocks(l)[bm], blocks(m)[bm]),
                        "sum_ratio": l[mask].sum() / m[mask].sum(), "mean_y_lucent": l[mask].mean(), "mean_y_mitsuba": m[mask].mean()}
        if case == "rgb":
            report[case]["channels"] = {name: {"blocks_4x4": ratios(blocks(lrgb[..., k])[bm], blocks(mrgb[..., k])[bm]),
                                               "sum_ratio": lrgb[..., k][mask].sum() / mrgb[..., k][mask].sum()}
                                        for k, name in enumerate("RGB")}
        if case == "sphere" and os.environ.get("EFFICIENCY"):
            report["efficiency"] = efficiency(a, work, vol, mask)
    if a.json:
        print(json.dumps(report, indent=2))
        return
    for case, r in report.items():
        if case == "efficiency":
            for name, e in r.items():
                print(f"sphere, {name}: per-pixel noise {e['noise']:.4f} over the medium, {e['cpu_s']:.2f} CPU-s per render, "
                      f"efficiency 1/(noise²·CPU-s) {e['efficiency']:.1f}")
            continue
        p, b = r["pixels"], r["blocks_4x4"]
        print(f"{case:7s} lucent / Mitsuba over the medium: pixels median {p['median']:.4f} ({p['p10']:.4f}–{p['p90']:.4f}, {p['count']} pixels), "
              f"4×4 blocks median {b['median']:.4f} ({b['p10']:.4f}–{b['p90']:.4f}, {b['count']} blocks), sum ratio {r['sum_ratio']:.4f} "
              f"(mean Y {r['mean_y_lucent']:.4f} / {r['mean_y_mitsuba']:.4f})")
        for name, c in r.get("channels", {}).items():
            b = c["blocks_4x4"]
            print(f"        {name}: 4×4 blocks median {b['median']:.4f} ({b['p10']:.4f}–{b['p90']:.4f}), sum ratio {c['sum_ratio']:.4f}")


if __name__ == "__main__":
    main()
