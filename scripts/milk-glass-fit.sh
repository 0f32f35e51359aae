#!/usr/bin/env bash
# The round trip of `lucent fit scene` with milk (docs/inverse.md, "The milk round trip"):
# render scenes/milk-film-fit.toml (a 0.5 mm layer of milk over black and white stripes) at its
# own values — 2 % fat, lamp scale 1 — with 131072 spp and seed 7, then fit fat content and lamp
# power from that image starting 50 % off (3 %, 1.5) with 16384 spp per evaluation and seed 1
# (other noise than the reference's; the same for every evaluation: common random numbers).
#   scripts/milk-glass-fit.sh [OUT_DIR] [extra `lucent fit scene` options]
# (The first attempt, a glass of milk with a BSSRDF, scenes/milk-glass-fit.toml, recovers the
# lamp but not the fat; its commands are in docs/inverse.md.)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
lucent=${LUCENT:-$root/target/release/lucent}
scene=$root/scenes/milk-film-fit.toml
out=${1:-milk-glass-fit}
shift || true
mkdir -p "$out"
# The starting scene: the scene file with fat and lamp 50 % high.
sed -e 's/fat_percent = 2.0,/fat_percent = 3.0,/' -e 's/^scale = 1$/scale = 1.5/' "$scene" > "$out/start.toml"
grep -q 'fat_percent = 3.0,' "$out/start.toml" && grep -q '^scale = 1.5$' "$out/start.toml"
[ -f "$out/reference.pfm" ] || nice -n 10 "$lucent" render "$scene" --spp 131072 --seed 7 --out "$out/reference.pfm" --quiet
time nice -n 10 "$lucent" fit scene "$out/start.toml" --reference "$out/reference.pfm" \
    --param objects.milk.medium.milk.fat_percent=0.5:5 --param spectra.lamp.scale=0.25:4 \
    --spp 16384 --seed 1 --tolerance 1e-5 --max-iterations 40 --out-dir "$out/fit" --json "$@"
