#!/usr/bin/env bash
# Round trip of `lucent fit scene` on the milk glass (issue 6; docs/inverse.md, "The milk glass"):
# render scenes/milk-glass-fit.toml at its own values (fat 1.5 %, lamp scale 4) with 1024 spp and
# seed 7, then fit fat content and lamp power from that image starting 50 % off (2.25 %, 6) with
# 64 spp per evaluation (`--unbiased`: two independent halves) and seed 1 (other noise than the reference's; the same for every
# evaluation: common random numbers).
#   scripts/milk-glass-fit.sh [OUT_DIR] [extra `lucent fit scene` options, e.g. --unbiased]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
lucent=${LUCENT:-$root/target/release/lucent}
out=${1:-milk-glass-fit}
shift || true
mkdir -p "$out"
# The starting scene: the scene file with fat and lamp 50 % high, meshes found from anywhere.
sed -e "s|\"meshes/|\"$root/scenes/meshes/|" \
    -e 's/^scale = 4$/scale = 6/' \
    -e 's/fat_percent = 1.5,/fat_percent = 2.25,/' \
    "$root/scenes/milk-glass-fit.toml" > "$out/start.toml"
grep -q 'fat_percent = 2.25,' "$out/start.toml" && grep -q '^scale = 6$' "$out/start.toml"
[ -f "$out/reference.exr" ] || "$lucent" render "$root/scenes/milk-glass-fit.toml" --spp 1024 --seed 7 --out "$out/reference.exr" --quiet
time "$lucent" fit scene "$out/start.toml" --reference "$out/reference.exr" \
    --param objects.milk.medium.milk.fat_percent=0.1:5 --param spectra.lamp.scale=1:10 \
    --spp 64 --seed 1 --unbiased --out-dir "$out/fit" --json "$@"
