#!/usr/bin/env python3
"""lucent `volpath` against Mitsuba 3 `volpathmis` on a whole-milk sphere behind a dielectric.

Renders scenes/milk-sphere.toml with lucent (two seeds; exact medium, then `similarity = true`
for information) and builds the same scene in Mitsuba 3 (two seeds, after an untimed warm-up
render that compiles the kernels), then reports for each renderer, over a mask of the sphere:

* the mean luminance Y (linear sRGB, 0.2126 R + 0.7152 G + 0.0722 B) of the two renders and its
  standard error; the means of lucent and Mitsuba must agree within a few standard errors for
  the comparison to be like-for-like (same optics, same radiance scale);
* sigma2_rel: the per-pixel variance of one render relative to the squared mean,
  mean over the mask of (A - B)^2 / 2, divided by mean(Y)^2;
* cpu_s: user + sys CPU seconds of one render (lucent: the child process, scene loading
  included; Mitsuba: this process, all its threads, the warm-up excluded);
* efficiency = 1 / (sigma2_rel * cpu_s): independent of the sample count (sigma2 ~ 1/spp,
  cpu ~ spp), so each renderer may use its own spp; the report gives lucent / Mitsuba.

Same scene in both: sphere radius 10 mm, smooth dielectric with relative index 1.35; inside it
a homogeneous medium with sigma_s(lambda), sigma_a(lambda) from the 1 nm table
scenes/spectra/whole-milk-3.5-hg.csv (360-830 nm; Mitsuba gets sigma_t = sigma_s + sigma_a and
albedo = sigma_s / sigma_t on the same 1 nm grid, linearly interpolated by its `irregular`
spectrum) and a Henyey-Greenstein phase function with the scene's constant g; a one-sided
40 mm x 40 mm area light of constant spectral radiance 1 and a constant environment of 0.2
(Mitsuba: `irregular` spectra over 360-830 nm, so no D65 factor is applied); pinhole camera,
vertical field of view, box pixel filter; unbounded depth in both (lucent max_depth = 10^9,
Mitsuba max_depth = -1), Russian roulette from depth 5 in both. The mask is the set of pixels
whose whole footprint lies on the sphere, from the camera geometry (the sphere is centred on the
optical axis, so the mask does not depend on either renderer's image orientation); a second
region, pixels at least 3 px outside the sphere's outline, sees the environment directly and
checks the radiance scale.

    # Mitsuba 3.9.1 with an LLVM backend (Debian's LLVM 14/15 aborts the JIT; Rust's works)
    export DRJIT_LIBLLVM_PATH=$(ls ~/.rustup/toolchains/stable-*/lib/libLLVM.so.*)
    /tmp/pyvenv/bin/python benches-peers/mitsuba_milk_sphere.py [--lucent target/release/lucent]
        [--spp 64] [--mitsuba-spp 256] [--exact-mitsuba-spp 4] [--threads 2] [--variant llvm_ad_spectral]
        [--mitsuba-rr-depth 5] [--no-similarity] [--save DIR] [--json]
    python3 benches-peers/mitsuba_milk_sphere.py --write-table   # regenerate the medium table
"""

import argparse
import json
import math
import os
import resource
import subprocess
import sys
import tempfile
import time
import tomllib

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCENE = os.path.join(ROOT, "scenes", "milk-sphere.toml")
TABLE = os.path.join(ROOT, "scenes", "spectra", "whole-milk-3.5-hg.csv")
LUMA = (0.2126, 0.7152, 0.0722)


def self_cpu():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def child_cpu():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def lucent_binary(arg):
    if arg:
        return arg
    return os.environ.get("LUCENT", os.path.join(ROOT, "target", "release", "lucent"))


def write_table(lucent):
    """The milk model's coefficients at 1 nm over 360-830 nm: linear between the model's
    wavelengths, held at the end values beyond them (as lucent does for `milk = {...}`)."""
    out = subprocess.run([lucent, "medium", "milk", "--fat-percent", "3.5", "--protein-percent", "3.4",
                          "--pressure-mpa", "20", "--json"], check=True, capture_output=True, text=True).stdout
    d = json.loads(out)
    w = d["wavelength_nm"]

    def interp(v, lam):
        if lam <= w[0]:
            return v[0]
        if lam >= w[-1]:
            return v[-1]
        i = max(k for k in range(len(w) - 1) if w[k] <= lam)
        t = (lam - w[i]) / (w[i + 1] - w[i])
        return v[i] * (1 - t) + v[i + 1] * t

    lams = list(range(360, 831))
    g_mean = sum(interp(d["g"], l) for l in lams) / len(lams)
    tmp = TABLE + ".tmp"
    with open(tmp, "w") as f:
        f.write("# Whole milk (3.5 % fat, 3.4 % protein, 20 MPa), lucent's milk model (optics::milk):\n")
        f.write("# `lucent medium milk --fat-percent 3.5 --json` at 375-775 nm every 25 nm, linear in between,\n")
        f.write("# held constant beyond; written by benches-peers/mitsuba_milk_sphere.py --write-table.\n")
        f.write(f"# Mean of g(lambda) over 360-830 nm: {g_mean:.4f} (the scene's Henyey-Greenstein g).\n")
        f.write("wavelength_nm,sigma_s_per_mm,sigma_a_per_mm\n")
        for l in lams:
            f.write(f"{l},{interp(d['sigma_s_per_mm'], l):.9g},{interp(d['sigma_a_per_mm'], l):.9g}\n")
    os.replace(tmp, TABLE)
    print(f"wrote {TABLE} (mean g {g_mean:.4f})")


def read_table():
    rows = []
    with open(TABLE) as f:
        for line in f:
            if line.startswith("#") or line.startswith("wavelength"):
                continue
            l, s, a = line.split(",")
            rows.append((float(l), float(s), float(a)))
    return rows


def read_pfm(path):
    import numpy as np
    with open(path, "rb") as f:
        kind = f.readline().strip()
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        data = np.frombuffer(f.read(), dtype="<f4" if scale < 0 else ">f4")
    ch = 3 if kind == b"PF" else 1
    return data.reshape(h, w, ch)[::-1].astype(np.float64)  # PFM rows run bottom to top


def masks(desc):
    """Pixels entirely on the sphere, and pixels that see only the environment."""
    import numpy as np
    cam = desc["camera"]
    w, h = cam["width"], cam["height"]
    sph = desc["objects"][0]["sphere"]
    eye, c, r = np.array(cam["eye"], float), np.array(sph["center"], float), float(sph["radius"])
    assert np.allclose(np.array(cam["look_at"], float), c), "the mask assumes the sphere on the optical axis"
    t = math.tan(math.radians(cam["vfov_deg"]) / 2)
    px = 2 * t / h  # pixel size on the image plane at unit distance
    alpha = math.asin(r / np.linalg.norm(c - eye))  # angular radius of the outline
    x = (np.arange(w) + 0.5 - w / 2) * px
    y = (np.arange(h) + 0.5 - h / 2) * px
    X, Y = np.meshgrid(x, y)
    rho = np.sqrt(X ** 2 + Y ** 2)  # tan of the angle off the axis
    edge = math.tan(alpha)
    sphere = rho + px / math.sqrt(2) * 1.5 < edge  # the footprint's farthest corner, with margin
    env = rho - 3 * px > edge
    return sphere, env


def lucent_runs(lucent, scene_path, spp, threads, seeds, tmp, save, tag):
    imgs, cpu, wall = [], [], []
    for s in seeds:
        out = os.path.join(tmp, f"{tag}-{s}.pfm")
        cmd = [lucent, "render", scene_path, "--spp", str(spp), "--seed", str(s), "--threads", str(threads),
               "--out", out, "--quiet"]
        c0, t0 = child_cpu(), time.perf_counter()
        r = subprocess.run(cmd, capture_output=True, text=True)
        t, c = time.perf_counter() - t0, child_cpu() - c0
        if r.returncode != 0:
            sys.exit(f"{' '.join(cmd)}: {r.stderr.strip()}")
        imgs.append(read_pfm(out))
        cpu.append(c)
        wall.append(t)
        if save:
            os.replace(out, os.path.join(save, os.path.basename(out)))
    return imgs, cpu, wall


def mitsuba_scene(mi, desc, table, spp, rr_depth):
    cam = desc["camera"]
    lams = ", ".join(f"{l:g}" for l, _, _ in table)
    sigma_t = ", ".join(f"{s + a:.9g}" for _, s, a in table)
    albedo = ", ".join(f"{s / (s + a):.9g}" for _, s, a in table)
    milk = desc["objects"][0]
    sph = milk["sphere"]
    med = milk["medium"]
    lamp = desc["lights"][0]
    env = desc["lights"][1]

    def flat(v):
        return {"type": "irregular", "wavelengths": "360, 830", "values": f"{v:g}, {v:g}"}

    T = mi.ScalarTransform4f
    return mi.load_dict({
        "type": "scene",
        "integrator": {"type": "volpathmis", "max_depth": -1, "rr_depth": rr_depth},
        "sensor": {
            "type": "perspective",
            "fov": cam["vfov_deg"],
            "fov_axis": "y",
            "to_world": T().look_at(origin=cam["eye"], target=cam["look_at"], up=cam["up"]),
            "sampler": {"type": "independent", "sample_count": spp},
            "film": {"type": "hdrfilm", "width": cam["width"], "height": cam["height"],
                     "rfilter": {"type": "box"}, "pixel_format": "rgb"},
        },
        "milk": {
            "type": "sphere", "center": sph["center"], "radius": sph["radius"],
            "bsdf": {"type": "dielectric", "int_ior": desc["materials"]["milk_surface"]["ior"], "ext_ior": 1.0},
            "interior": {
                "type": "homogeneous",
                "sigma_t": {"type": "irregular", "wavelengths": lams, "values": sigma_t},
                "albedo": {"type": "irregular", "wavelengths": lams, "values": albedo},
                "phase": {"type": "hg", "g": med["g"]},
            },
        },
        # the lamp quad of the scene: centre (0, 40, -20), 40 x 40, facing -y (Mitsuba's rectangle
        # is [-1, 1]^2 in z = 0 facing +z; rotating +90 degrees about x turns +z into -y)
        "lamp": {
            "type": "rectangle",
            "to_world": T().translate([0, 40, -20]) @ T().rotate([1, 0, 0], 90) @ T().scale(20),
            "bsdf": {"type": "diffuse", "reflectance": 0.0},
            "emitter": {"type": "area", "radiance": flat(lamp["radiance"])},
        },
        "env": {"type": "constant", "radiance": flat(env["radiance"])},
    })


def mitsuba_runs(variant, desc, table, spp, threads, seeds, rr_depth, save):
    import drjit as dr
    import numpy as np
    import mitsuba as mi
    mi.set_variant(variant)
    if threads > 0:
        dr.set_thread_count(threads)
    scene = mitsuba_scene(mi, desc, table, spp, rr_depth)
    t0, c0 = time.perf_counter(), self_cpu()
    img = mi.render(scene, seed=0, spp=1)  # warm-up: kernel compilation (not timed)
    dr.eval(img)
    dr.sync_thread()
    warm = (time.perf_counter() - t0, self_cpu() - c0)
    imgs, cpu, wall = [], [], []
    for s in seeds:
        t0, c0 = time.perf_counter(), self_cpu()
        img = mi.render(scene, seed=s, spp=spp)  # spp given again: the warm-up's spp=1 sticks to the sampler
        dr.eval(img)
        dr.sync_thread()
        wall.append(time.perf_counter() - t0)
        cpu.append(self_cpu() - c0)
        imgs.append(np.array(img, dtype=np.float64)[:, :, :3])
        if save:
            mi.util.write_bitmap(os.path.join(save, f"mitsuba-rr{rr_depth}-{s}.exr"), img)
    return imgs, cpu, wall, warm


def stats(imgs, cpu, wall, spp, sphere, env):
    import numpy as np
    a, b = (np.tensordot(i, LUMA, axes=([2], [0])) for i in imgs)
    n = int(sphere.sum())
    d2 = ((a - b) ** 2 / 2)[sphere]
    mean = float(((a + b) / 2)[sphere].mean())
    var = float(d2.mean())  # per-pixel variance of one render
    rgb = [float(((imgs[0][..., k] + imgs[1][..., k]) / 2)[sphere].mean()) for k in range(3)]
    rgb_se = [math.sqrt(float(((imgs[0][..., k] - imgs[1][..., k]) ** 2 / 2)[sphere].mean()) / (2 * n))
              for k in range(3)]
    cpu_s = sum(cpu) / len(cpu)
    s2 = var / mean ** 2
    return {
        "spp": spp,
        "mask_px": n,
        "mean_y": mean,
        "mean_y_se": math.sqrt(var / (2 * n)),
        "mean_rgb": rgb,
        "mean_rgb_se": rgb_se,
        "sigma2_rel": s2,
        "noise_rel": math.sqrt(s2),
        "largest_pixel_share_of_sigma2": float(d2.max() / d2.sum()),
        "cpu_s": cpu,
        "wall_s": wall,
        "efficiency_per_cpu_s": 1.0 / (s2 * cpu_s),
        "env_mean_y": float(((a + b) / 2)[env].mean()),
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lucent", help="lucent binary (default: $LUCENT, else target/release/lucent)")
    ap.add_argument("--spp", type=int, default=64, help="lucent samples per pixel per render")
    ap.add_argument("--mitsuba-spp", type=int, default=256)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--variant", default="llvm_ad_spectral")
    ap.add_argument("--mitsuba-rr-depth", type=int, default=5)
    ap.add_argument("--exact-mitsuba-spp", type=int, default=4,
                    help="spp of the Mitsuba reference without Russian roulette (rr_depth = 10^9) that checks the "
                         "mean; 0 skips it")
    ap.add_argument("--seeds", default="1,2", help="two seeds, comma-separated")
    ap.add_argument("--no-similarity", action="store_true", help="skip the similarity = true renders")
    ap.add_argument("--no-mitsuba", action="store_true")
    ap.add_argument("--save", help="keep the images in this folder")
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--write-table", action="store_true", help="regenerate the medium table and stop")
    a = ap.parse_args()
    lucent = lucent_binary(a.lucent)
    if a.write_table:
        return write_table(lucent)
    try:
        seeds = [int(s) for s in a.seeds.split(",")]
    except ValueError:
        seeds = []
    if len(seeds) != 2 or seeds[0] == seeds[1]:
        sys.exit(f"--seeds: expected two different integer seeds, e.g. 1,2, got {a.seeds!r}")
    if not os.access(lucent, os.X_OK):
        sys.exit(f"{lucent}: not an executable lucent (build it with `cargo build --release -p lucent`)")
    with open(SCENE, "rb") as f:
        desc = tomllib.load(f)
    table = read_table()
    sphere, env = masks(desc)
    if a.save:
        os.makedirs(a.save, exist_ok=True)
    res = {"scene": os.path.relpath(SCENE, ROOT), "threads": a.threads}
    with tempfile.TemporaryDirectory() as tmp:
        imgs, cpu, wall = lucent_runs(lucent, SCENE, a.spp, a.threads, seeds, tmp, a.save, "lucent")
        res["lucent"] = stats(imgs, cpu, wall, a.spp, sphere, env)
        if not a.no_similarity:
            with open(SCENE) as f:
                text = f.read()
            text = text.replace('csv = "spectra/', f'csv = "{os.path.join(ROOT, "scenes", "spectra")}/')
            text = text.replace("g = 0.849 }", "g = 0.849, similarity = true }")
            assert "similarity = true" in text, "scenes/milk-sphere.toml: medium line not found"
            sim = os.path.join(tmp, "milk-sphere-similarity.toml")
            with open(sim, "w") as f:
                f.write(text)
            imgs, cpu, wall = lucent_runs(lucent, sim, a.spp, a.threads, seeds, tmp, a.save, "lucent-similarity")
            res["lucent_similarity"] = stats(imgs, cpu, wall, a.spp, sphere, env)
    if not a.no_mitsuba:
        imgs, cpu, wall, warm = mitsuba_runs(a.variant, desc, table, a.mitsuba_spp, a.threads, seeds,
                                             a.mitsuba_rr_depth, a.save)
        m = stats(imgs, cpu, wall, a.mitsuba_spp, sphere, env)
        m.update({"variant": a.variant, "integrator": "volpathmis", "rr_depth": a.mitsuba_rr_depth,
                  "warmup_wall_s": warm[0], "warmup_cpu_s": warm[1]})
        res["mitsuba"] = m
        l = res["lucent"]
        res["mean_y_lucent_minus_mitsuba_in_se"] = (l["mean_y"] - m["mean_y"]) / math.hypot(l["mean_y_se"], m["mean_y_se"])
        res["efficiency_lucent_over_mitsuba"] = l["efficiency_per_cpu_s"] / m["efficiency_per_cpu_s"]
        if a.exact_mitsuba_spp > 0:
            rr = 10 ** 9
            imgs, cpu, wall, warm = mitsuba_runs(a.variant, desc, table, a.exact_mitsuba_spp, a.threads, seeds, rr,
                                                 a.save)
            e = stats(imgs, cpu, wall, a.exact_mitsuba_spp, sphere, env)
            e.update({"variant": a.variant, "integrator": "volpathmis", "rr_depth": rr,
                      "warmup_wall_s": warm[0], "warmup_cpu_s": warm[1]})
            res["mitsuba_no_roulette"] = e
            res["mean_y_lucent_minus_mitsuba_no_roulette_in_se"] = \
                (l["mean_y"] - e["mean_y"]) / math.hypot(l["mean_y_se"], e["mean_y_se"])
            res["efficiency_lucent_over_mitsuba_no_roulette"] = l["efficiency_per_cpu_s"] / e["efficiency_per_cpu_s"]
    res["loadavg"] = os.getloadavg()
    if a.json:
        print(json.dumps(res))
        return
    for k in ("lucent", "lucent_similarity", "mitsuba", "mitsuba_no_roulette"):
        if k not in res:
            continue
        s = res[k]
        print(f"{k:19s} {s['spp']:5d} spp  mean Y {s['mean_y']:.5f} ± {s['mean_y_se']:.5f}  "
              f"rel. noise/px {s['noise_rel']:.3f}  CPU {sum(s['cpu_s']) / 2:7.1f} s "
              f"(wall {sum(s['wall_s']) / 2:6.1f} s)  efficiency {s['efficiency_per_cpu_s']:.4g} /CPU-s  "
              f"env Y {s['env_mean_y']:.5f}  max px share {s['largest_pixel_share_of_sigma2']:.3f}")
    if "mitsuba" in res:
        print(f"mean Y lucent - Mitsuba: {res['mean_y_lucent_minus_mitsuba_in_se']:+.2f} standard errors; "
              f"efficiency lucent / Mitsuba: {res['efficiency_lucent_over_mitsuba']:.3g}")
    if "mitsuba_no_roulette" in res:
        print(f"mean Y lucent - Mitsuba without roulette: {res['mean_y_lucent_minus_mitsuba_no_roulette_in_se']:+.2f} "
              f"standard errors; efficiency lucent / Mitsuba without roulette: "
              f"{res['efficiency_lucent_over_mitsuba_no_roulette']:.3g}")
    print(f"load average {res['loadavg']}")


if __name__ == "__main__":
    sys.exit(main())
