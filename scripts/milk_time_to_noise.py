#!/usr/bin/env python3
"""Time to noise of the three milks of scenes/milk-glass.toml at its full size (480x240).

usage (from the repository root; python3 with numpy, e.g. /tmp/pyvenv/bin/python):
    scripts/milk_time_to_noise.py [--spp 4,16,64] [--threads 2] [--lucent BIN] [--scene FILE]
        [--similarity] [--save DIR] [--json]

1. Masks. The scene is rewritten three times with one milk body made an emitter of constant
   spectral radiance 1 (two-sided, on a black material, its medium removed), every other object
   black except the glass tumblers (unchanged dielectric), and no other light; rendered with
   `path` (16 segments, no roulette) at 16 spp. A pixel's value is then the fraction of its
   footprint that sees that milk, directly or through the glass (refraction and Fresnel
   included). A body's mask is the set of pixels with luminance Y >= 0.5 in its own mask render
   and Y < 0.1 in each of the other two (a glass also shows its neighbour's milk near its edge).
2. Curve. For each spp, the unchanged scene is rendered twice (seeds 1 and 2) with
   `--threads N`; CPU time is user + sys of the lucent process (scene set-up, Mie included).
   For each body the script reports, on Y = 0.2126 R + 0.7152 G + 0.0722 B of linear sRGB:
   * noise: the per-pixel relative noise of ONE render, sqrt(mean over the mask of (A - B)^2 / 2)
     divided by the mean of Y over the mask (the rms form, as scripts/pfm_noise.py);
   * cpu_to_5pct: the CPU seconds for one render to reach noise 0.05, extrapolated from this
     point with noise ~ 1/sqrt(CPU) (an extrapolation, not a measurement).
With --similarity every milk medium gets `similarity = true` (the opt-in approximation).
LUCENT=BIN works like --lucent. Outputs are read from a temporary folder (kept with --save,
which also writes masks.png: the first render (gamma 2.2) with each body's mask tinted red, green,
blue in the order of the scene's objects).
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

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
LUMA = np.array([0.2126, 0.7152, 0.0722])
MASK_Y = 0.5
OTHER_Y = 0.1
TARGET = 0.05


def toml_value(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {toml_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(f"cannot write {v!r} as TOML")


def toml_dump(desc):
    """TOML for a scene description: top-level values, [tables] (a table of tables becomes
    [name.key] sections) and [[arrays of tables]]; checked by reading it back."""
    top, sections = [], []
    for k, v in desc.items():
        if isinstance(v, dict) and v and all(isinstance(x, dict) for x in v.values()) and k != "medium":
            for name, t in v.items():
                sections.append(f"[{k}.{name}]\n" + "".join(f"{a} = {toml_value(b)}\n" for a, b in t.items()))
        elif isinstance(v, dict) and k != "medium":
            sections.append(f"[{k}]\n" + "".join(f"{a} = {toml_value(b)}\n" for a, b in v.items()))
        elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
            for t in v:
                sections.append(f"[[{k}]]\n" + "".join(f"{a} = {toml_value(b)}\n" for a, b in t.items()))
        else:
            top.append(f"{k} = {toml_value(v)}\n")
    text = "".join(top) + "\n" + "\n".join(sections)
    assert tomllib.loads(text) == desc, "TOML writer: round trip failed"
    return text


def load_scene(path):
    try:
        with open(path, "rb") as f:
            desc = tomllib.load(f)
    except (OSError, tomllib.TOMLDecodeError) as e:
        sys.exit(f"{path}: {e}")
    base = os.path.dirname(os.path.abspath(path))
    for o in desc.get("objects", []):  # the rewritten scenes live elsewhere: absolute mesh paths
        if "mesh" in o:
            o["mesh"] = os.path.join(base, o["mesh"])
    for s in desc.get("spectra", {}).values():
        if "csv" in s:
            s["csv"] = os.path.join(base, s["csv"])
    return desc


def milk_bodies(desc):
    names = [o.get("name") for o in desc["objects"] if "medium" in o]
    if None in names:
        sys.exit("scene: every object with a medium needs a `name` (its mask render makes it a light)")
    return names


def mask_scene(desc, body):
    d = json.loads(json.dumps(desc))
    d["integrator"] = {"type": "path", "max_depth": 16, "rr_depth": 16}
    d["materials"]["mask_black"] = {"type": "black"}
    glass = {n for n, m in d["materials"].items() if m.get("type") in ("dielectric", "rough_dielectric")}
    for o in d["objects"]:
        if "medium" in o or o["material"] not in glass:
            o["material"] = "mask_black"
        o.pop("medium", None)
    d["lights"] = [{"type": "area", "object": body, "radiance": 1.0, "two_sided": True}]
    return d


def read_pfm(path):
    with open(path, "rb") as f:
        assert f.readline().strip() == b"PF", f"{path}: not an RGB PFM"
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        a = np.frombuffer(f.read(), dtype="<f4" if scale < 0 else ">f4").reshape(h, w, 3)
    return a[::-1].astype(np.float64)


def write_png(path, rgb):
    """8-bit RGB PNG (stdlib zlib), written to a temporary name and renamed."""
    import struct
    import zlib
    a = (np.clip(rgb, 0, 1) * 255 + 0.5).astype(np.uint8)
    h, w, _ = a.shape
    raw = b"".join(b"\x00" + a[y].tobytes() for y in range(h))

    def chunk(t, d):
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xFFFFFFFF)

    with open(path + ".tmp", "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)) +
                chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))
    os.replace(path + ".tmp", path)


def child_cpu():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def render(lucent, scene, out, args):
    cmd = [lucent, "render", scene, "--out", out, "--quiet"] + args
    c0, t0 = child_cpu(), time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True)
    wall, cpu = time.perf_counter() - t0, child_cpu() - c0
    if r.returncode != 0:
        sys.exit(f"{' '.join(cmd)}: {r.stderr.strip()}")
    rgb = read_pfm(out)
    return rgb @ LUMA, cpu, wall, rgb


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default=os.path.join(ROOT, "scenes", "milk-glass.toml"))
    ap.add_argument("--spp", default="4,16,64", help="comma-separated sample counts")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--lucent", default=os.environ.get("LUCENT", os.path.join(ROOT, "target", "release", "lucent")))
    ap.add_argument("--similarity", action="store_true", help="similarity = true on every milk medium")
    ap.add_argument("--save", help="keep the scenes and images in this folder")
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args()
    try:
        spps = [int(s) for s in a.spp.split(",")]
        assert all(n > 0 for n in spps)
    except (ValueError, AssertionError):
        sys.exit(f"--spp: expected positive integers separated by commas, got {a.spp!r}")
    if not os.access(a.lucent, os.X_OK):
        sys.exit(f"{a.lucent}: not an executable lucent (build it with `cargo build --release -p lucent`)")
    desc = load_scene(a.scene)
    bodies = milk_bodies(desc)
    if not bodies:
        sys.exit(f"{a.scene}: no object with a medium")
    if a.similarity:
        for o in desc["objects"]:
            if "medium" in o:
                o["medium"]["similarity"] = True
    tmp_obj = tempfile.TemporaryDirectory()
    work = a.save or tmp_obj.name
    os.makedirs(work, exist_ok=True)
    res = {"scene": os.path.relpath(os.path.abspath(a.scene), ROOT), "threads": a.threads,
           "similarity": a.similarity, "mask_y": MASK_Y, "other_y": OTHER_Y, "bodies": {}, "points": []}

    ys = {}
    for b in bodies:
        sc = os.path.join(work, f"mask-{b}.toml")
        with open(sc, "w") as f:
            f.write(toml_dump(mask_scene(desc, b)))
        y, _, _, _ = render(a.lucent, sc, os.path.join(work, f"mask-{b}.pfm"), ["--spp", "16", "--seed", "7",
                                                                          "--threads", str(a.threads)])
        ys[b] = y
    masks = {}
    for b in bodies:
        masks[b] = (ys[b] >= MASK_Y) & np.all([ys[o] < OTHER_Y for o in bodies if o != b], axis=0)
        res["bodies"][b] = {"mask_px": int(masks[b].sum())}

    sc = os.path.join(work, "scene.toml")
    with open(sc, "w") as f:
        f.write(toml_dump(desc))
    for spp in spps:
        ys, cpus, walls = [], [], []
        for seed in (1, 2):
            y, cpu, wall, rgb = render(a.lucent, sc, os.path.join(work, f"render-{spp}spp-seed{seed}.pfm"),
                                       ["--spp", str(spp), "--seed", str(seed), "--threads", str(a.threads)])
            if a.save and spp == spps[0] and seed == 1:
                over = np.clip(rgb, 0, 1) ** (1 / 2.2)
                for k, b in enumerate(bodies):
                    over[masks[b]] = 0.5 * over[masks[b]] + 0.5 * np.eye(3)[k % 3]
                write_png(os.path.join(work, "masks.png"), over)
            ys.append(y)
            cpus.append(cpu)
            walls.append(wall)
        cpu = sum(cpus) / 2
        p = {"spp": spp, "cpu_s": cpus, "wall_s": walls, "bodies": {}}
        for b in bodies:
            m = masks[b]
            mean = float(((ys[0] + ys[1]) / 2)[m].mean())
            noise = math.sqrt(float(((ys[0] - ys[1]) ** 2 / 2)[m].mean())) / mean
            p["bodies"][b] = {"mean_y": mean, "noise": noise, "cpu_to_5pct": cpu * (noise / TARGET) ** 2}
        res["points"].append(p)
        if not a.json:
            print(f"{spp:5d} spp  CPU {cpus[0]:7.1f} {cpus[1]:7.1f} s  wall {walls[0]:6.1f} {walls[1]:6.1f} s  " +
                  "  ".join(f"{b}: noise {q['noise'] * 100:5.1f} % (Y {q['mean_y']:.3f}, 5 % at ~{q['cpu_to_5pct']:.0f} CPU-s)"
                            for b, q in p["bodies"].items()), flush=True)
    res["loadavg"] = os.getloadavg()
    if a.json:
        print(json.dumps(res))
    else:
        print("mask pixels: " + ", ".join(f"{b} {v['mask_px']}" for b, v in res["bodies"].items()) +
              f"; load average {res['loadavg']}")


if __name__ == "__main__":
    sys.exit(main())
