#!/usr/bin/env python3
"""The measured Cornell box (scenes/cornell-box.toml) in Mitsuba 3, timed warm.

Builds the same scene from the TOML file (the 16 published quads split into triangles (a,b,c),
(a,c,d); measured reflectances and emission as irregular spectra, zero outside 400-700 nm;
pinhole camera, vertical field of view; box pixel filter) and renders it with Mitsuba 3's `path`
integrator, unbounded depth (max_depth = -1), Russian roulette from depth 5, independent sampler.
The first render compiles the kernels (not timed); the following `--repeats` renders are timed,
each with its own seed, reporting wall time, process CPU time (user+sys, all threads) and
Msamples per wall and CPU second.

    pip install mitsuba==3.9.1
    # drjit's LLVM backend needs a recent libLLVM: with Debian's LLVM 14/15 the JIT aborts
    # ("Cannot select ... fminimum"); Debian's LLVM 19 (apt install libllvm19) and Rust's own
    # LLVM 22 both work and run at the same speed here:
    export DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM-19.so
    # or: export DRJIT_LIBLLVM_PATH=$(ls ~/.rustup/toolchains/*/lib/libLLVM.so.* | head -1)
    python3 benches-peers/mitsuba_cornell.py [--variant llvm_ad_spectral] [--size 128] [--spp 256]
        [--repeats 3] [--threads 2] [--json] [--exr out.exr]
"""

import argparse
import csv
import json
import os
import resource
import sys
import tempfile
import time
import tomllib

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def cpu_seconds():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def read_spectra(scene_path, spectra):
    out = {}
    base = os.path.dirname(scene_path)
    for name, s in spectra.items():
        rows = []
        with open(os.path.join(base, s["csv"])) as f:
            lines = [l for l in f if not l.startswith("#")]
        for row in csv.DictReader(lines):
            rows.append((float(row["wavelength_nm"]), float(row[s["column"]]) * s.get("scale", 1.0)))
        out[name] = rows
    return out


def build(mi, scene_path, size, spp, tmp):
    with open(scene_path, "rb") as f:
        desc = tomllib.load(f)
    spectra = read_spectra(scene_path, desc["spectra"])

    def spec(name, scale=1.0):
        rows = spectra[name]
        return {"type": "irregular", "wavelengths": ", ".join(f"{w:g}" for w, _ in rows),
                "values": ", ".join(f"{v * scale:g}" for _, v in rows)}

    cam = desc["camera"]
    d = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": -1, "rr_depth": 5},
        "sensor": {
            "type": "perspective",
            "fov": cam["vfov_deg"],
            "fov_axis": "y",
            "to_world": mi.ScalarTransform4f().look_at(origin=cam["eye"], target=cam["look_at"], up=cam["up"]),
            "sampler": {"type": "independent", "sample_count": spp},
            "film": {"type": "hdrfilm", "width": size, "height": size, "rfilter": {"type": "box"}, "pixel_format": "rgb"},
        },
    }
    bsdfs = {n: {"type": "diffuse", "reflectance": spec(m["albedo"])} for n, m in desc["materials"].items()}
    lights = {l["object"]: l for l in desc["lights"]}
    for k, o in enumerate(desc["objects"]):
        quads = o.get("quads") or [o["quad"]]
        path = os.path.join(tmp, f"{o['name']}.obj")
        with open(path, "w") as f:
            for q in quads:
                for v in q:
                    f.write("v %g %g %g\n" % tuple(v))
            for i in range(len(quads)):
                a = 4 * i + 1
                f.write(f"f {a} {a + 1} {a + 2}\nf {a} {a + 2} {a + 3}\n")
        shape = {"type": "obj", "filename": path, "face_normals": True, "bsdf": bsdfs[o["material"]]}
        if o["name"] in lights:
            l = lights[o["name"]]
            shape["emitter"] = {"type": "area", "radiance": spec(l["radiance"], l.get("scale", 1.0))}
        d[f"shape_{k}_{o['name']}"] = shape
    return mi.load_dict(d)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--variant", default="llvm_ad_spectral")
    ap.add_argument("--scene", default=os.path.join(ROOT, "scenes", "cornell-box.toml"))
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--threads", type=int, default=0, help="worker threads (0: all cores)")
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--exr", help="write the last image here")
    a = ap.parse_args()

    import drjit as dr
    import numpy as np
    import mitsuba as mi

    mi.set_variant(a.variant)
    if a.threads > 0:
        dr.set_thread_count(a.threads)
    with tempfile.TemporaryDirectory() as tmp:
        scene = build(mi, a.scene, a.size, a.spp, tmp)
        img = mi.render(scene, seed=0)  # warm-up: kernel compilation
        dr.eval(img)
        dr.sync_thread()
        runs = []
        for r in range(a.repeats):
            t0, c0 = time.perf_counter(), cpu_seconds()
            img = mi.render(scene, seed=r + 1)
            dr.eval(img)
            dr.sync_thread()
            t, c = time.perf_counter() - t0, cpu_seconds() - c0
            runs.append((t, c))
        if a.exr:
            mi.util.write_bitmap(a.exr, img)
    samples = a.size * a.size * a.spp
    out = {
        "variant": a.variant,
        "samples": samples,
        "wall_s": [t for t, _ in runs],
        "cpu_s": [c for _, c in runs],
        "msamples_per_s": [samples / t / 1e6 for t, _ in runs],
        "msamples_per_cpu_s": [samples / c / 1e6 for _, c in runs],
        "mean_rgb": [float(x) for x in np.array(img).reshape(-1, 3).mean(axis=0)],
        "loadavg": os.getloadavg(),
    }
    if a.json:
        print(json.dumps(out))
    else:
        for (t, c) in runs:
            print(f"{a.variant}: {t:.3f} s wall, {c:.3f} s CPU: {samples / t / 1e6:.3f} Msamples/s, {samples / c / 1e6:.3f} per CPU-s")
        print(f"load average {out['loadavg']}")


if __name__ == "__main__":
    sys.exit(main())
