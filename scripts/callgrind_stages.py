#!/usr/bin/env python3
"""Instructions per camera sample by stage of the path tracer, from two callgrind runs.

Run the same render twice under callgrind with different sample counts (one thread), e.g.

    for spp in 16 32; do
      valgrind --tool=callgrind --callgrind-out-file=/tmp/cg.$spp target/release/lucent render \\
        scenes/cornell-box.toml --width 32 --height 32 --spp $spp --max-depth 100000 --threads 1 \\
        --quiet --out /tmp/cg.exr
    done
    python3 scripts/callgrind_stages.py /tmp/cg.16 /tmp/cg.32 16384

The difference of the two runs is what the extra samples (third argument: extra camera samples,
here 32×32×16) cost, with loading, table set-up and image output cancelled. Lines are grouped by
the source file of the (possibly inlined) code and the function it was inlined into (callgrind_annotate
`file:function` lines), so inlined helpers are charged to their own stage.
"""

import re
import subprocess
import sys
from collections import defaultdict

STAGES = [
    ("camera", lambda f, fn: "/camera/" in f or "Camera::" in fn),
    ("RNG and sample warps", lambda f, fn: f.endswith("math/sampling.rs")),
    ("spectral (wavelengths, spectra, XYZ)", lambda f, fn: f.endswith("math/spectral.rs") or "SampledWavelengths" in fn or "optics/src/spectrum" in f),
    ("BSDF and material", lambda f, fn: "/bsdf/" in f or "/material/" in f or "/texture/" in f or "Bsdf::" in fn or "Material::" in fn),
    ("traversal: closest hit", lambda f, fn: "Accel::intersect" in fn),
    ("traversal: shadow rays", lambda f, fn: "Accel::occluded" in fn or "unoccluded" in fn),
    ("hit -> shading point", lambda f, fn: "surface_point" in fn or "make_hit" in fn or f.endswith("interaction.rs") or "Shading::" in fn),
    ("light sampling and MIS", lambda f, fn: "/light/" in f or f.endswith("nee.rs") or f.endswith("scene.rs") or "nee::" in fn or "Light::" in fn),
    ("path loop", lambda f, fn: "li_path" in fn or "path.rs" in f),
    ("film and pass loop", lambda f, fn: "film.rs" in f or "integrator/mod.rs" in f or "render_pass" in fn or "call_mut" in fn or "progressive" in f),
]


def stages(path):
    out = subprocess.run(["callgrind_annotate", "--auto=no", "--threshold=100", path], capture_output=True, text=True, check=True).stdout
    acc = defaultdict(int)
    for line in out.splitlines():
        m = re.match(r"^\s*([\d,]+)\s+\(\s*[\d.]+%\)\s+(.*?):(.*?)(\s+\[.*\])?$", line)
        if not m or "PROGRAM TOTALS" in line:
            continue
        ir = int(m.group(1).replace(",", ""))
        f, fn = m.group(2), m.group(3)
        for name, rule in STAGES:
            if rule(f, fn):
                acc[name] += ir
                break
        else:
            acc["other"] += ir
    return acc


def main():
    a, b, n = stages(sys.argv[1]), stages(sys.argv[2]), float(sys.argv[3])
    total = sum(b.values()) - sum(a.values())
    print(f"{'stage':40s} {'instr/sample':>12s} {'share':>7s}")
    for name in [s for s, _ in STAGES] + ["other"]:
        d = b.get(name, 0) - a.get(name, 0)
        print(f"{name:40s} {d / n:12.0f} {100 * d / total:6.1f}%")
    print(f"{'total':40s} {total / n:12.0f}")


if __name__ == "__main__":
    main()
