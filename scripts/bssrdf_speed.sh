#!/usr/bin/env bash
# Time to equal noise, BSSRDF (point-cloud method) vs volumetric path tracing, on one scene
# (the speed check of docs/validation.md, "Speed").
#   scripts/bssrdf_speed.sh [SCENE] [WIDTH] [HEIGHT] [SEED_A] [SEED_B] [VOLPATH_SPP] [BSSRDF_SPP]
# Renders the scene twice (two seeds) with each method, takes each render's CPU time (user + sys,
# so other jobs on the machine do not count) and the per-pixel noise σ = rms(A − B)/√2 of
# (R+G+B)/3 over the box 0.3–0.7 × 0.2–0.85 of the frame (the bunny's body), and prints
# σ²·CPU for both and their ratio (time to equal noise scales with σ²·CPU).
set -euo pipefail
scene=${1:-scenes/marble-bunny.toml}
w=${2:-512}; h=${3:-512}; sa=${4:-1}; sb=${5:-2}; vspp=${6:-64}; bspp=${7:-16}
bin=${LUCENT:-target/release/lucent}
out=${OUT:-/tmp/bssrdf_speed}
mkdir -p "$out"
run() { # name seed extra-args...
  local name=$1 seed=$2; shift 2
  /usr/bin/time -f "%U %S" -o "$out/$name-$seed.time" \
    "$bin" render "$scene" --width "$w" --height "$h" --seed "$seed" --out "$out/$name-$seed.pfm" -q "$@"
}
for s in "$sa" "$sb"; do
  run volpath "$s" --integrator volpath --max-depth 100000 --spp "$vspp"
  run bssrdf "$s" --spp "$bspp"
done
python3 - "$out" "$sa" "$sb" "$vspp" "$bspp" <<'PY'
import sys, numpy as np
out, sa, sb, vspp, bspp = sys.argv[1:]
def pfm(p):
    with open(p, "rb") as f:
        f.readline(); w, h = map(int, f.readline().split()); sc = float(f.readline())
        # PFM rows run bottom to top: flip so that y fractions count from the top, as in render_pass.
        return np.frombuffer(f.read(), dtype="<f4" if sc < 0 else ">f4").reshape(h, w, 3)[::-1].astype(np.float64)
def cpu(p):
    return sum(map(float, open(p).read().split()[-2:]))
res = {}
for name, spp in (("volpath", vspp), ("bssrdf", bspp)):
    a, b = pfm(f"{out}/{name}-{sa}.pfm"), pfm(f"{out}/{name}-{sb}.pfm")
    h, w, _ = a.shape
    box = (slice(int(0.2 * h), int(0.85 * h)), slice(int(0.3 * w), int(0.7 * w)))
    ya, yb = a[box].mean(axis=2), b[box].mean(axis=2)
    sigma = np.sqrt(np.mean((ya - yb) ** 2) / 2)
    c = 0.5 * (cpu(f"{out}/{name}-{sa}.time") + cpu(f"{out}/{name}-{sb}.time"))
    res[name] = sigma ** 2 * c
    print(f"{name:8s} spp {spp:>4s}  CPU {c:6.1f} s  box mean {0.5 * (ya.mean() + yb.mean()):.4f}  "
          f"sigma {sigma:.4f}  sigma^2*CPU {sigma ** 2 * c:.4f}")
print(f"speed-up (time to equal noise): {res['volpath'] / res['bssrdf']:.1f}x")
PY
