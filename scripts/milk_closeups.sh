#!/bin/bash
# Time and noise of the milk in scenes/milk-glass.toml (docs/milk-glass.md): a 32×32 close-up
# (vfov 4°, all milk) of the front of each glass, from the same eye as the full scene, rendered
# twice (seeds 1 and 2) on one thread; prints CPU seconds and scripts/pfm_noise.py's numbers.
#   scripts/milk_closeups.sh [SPP] [similarity]      (run from the repository root)
set -e
spp=${1:-32}
bin=${LUCENT:-target/release/lucent}
out=${OUT:-/tmp/milk-closeups}
mkdir -p "$out"
for v in skim:-85 lowfat:0 whole:85; do
  n=${v%%:*}; x=${v##*:}
  sc="$out/closeup-$n.toml"
  sed -e "s|^look_at = .*|look_at = [$x, 40, -30]|" -e "s|^vfov_deg = .*|vfov_deg = 4|" \
      -e "s|^width = .*|width = 32|" -e "s|^height = .*|height = 32|" \
      -e "s|\"meshes/|\"$PWD/scenes/meshes/|" scenes/milk-glass.toml > "$sc"
  if [ "$2" = similarity ]; then
    sed -i 's/pressure_mpa = 20 } }/pressure_mpa = 20 }, similarity = true }/' "$sc"
  fi
  cpu=""
  for s in 1 2; do
    /usr/bin/time -f "%U" -o "$out/$n-$s.cpu" "$bin" render "$sc" --spp "$spp" --threads 1 --seed $s --out "$out/$n-$s.pfm" -q >/dev/null
    cpu="$cpu $(cat "$out/$n-$s.cpu")"
  done
  echo "$n ${2:-exact} ${spp} spp, CPU s:$cpu | $(python3 scripts/pfm_noise.py "$out/$n-1.pfm" "$out/$n-2.pfm")"
done
