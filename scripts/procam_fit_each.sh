#!/bin/bash
# The walk-through of docs/digitization.md with capture P of the shared procam set as the scanned,
# labelled and fitted capture, predicting the other two:
#   scripts/procam_fit_each.sh P [FILL] [SPP] [pairs] (from the repository root, after
#                                             `cargo build --release -p lucent` and the walk-through's
#                                             steps 1: digit/calib.json and digit/patterns/)
# FILL is `scan reconstruct --fill-holes` (default 40: fills the black squares, which the decoding
# leaves as holes in the oblique captures); SPP is `fit photo --spp` (default 4, the walk-through's);
# `pairs` adds `fit photo --gamma-from-pairs` (the camera's gamma from complementary frames, held).
# Writes digit/fit-each/cP-fFILL/ (cP-fFILL-sSPP/ for another SPP, -pairs appended with `pairs`): the scan, the labels
# and the scenes of all three captures (labels moved by the relative board poses), and fit/ with
# fit.json and the panels; prints the fit's summary. scripts/procam_fit_table.py turns fit.json
# into the per-frame table of the doc.
set -euo pipefail
P=${1:?usage: scripts/procam_fit_each.sh P [FILL] [SPP] [pairs]}
FILL=${2:-40}
SPP=${3:-4}
EXTRA=()
case "${4:-}" in
  "") ;;
  pairs) EXTRA=(--gamma-from-pairs) ;;
  *) echo "procam_fit_each.sh: the fourth argument is \`pairs\` or nothing, got \`$4\`" >&2; exit 1 ;;
esac
S=${S:-../shared/data/structured-light/procam-sample}
L=${LUCENT:-target/release/lucent}
D=digit/fit-each/c$P-f$FILL
[ "$SPP" = 4 ] || D=$D-s$SPP
[ ${#EXTRA[@]} = 0 ] || D=$D-pairs
for f in digit/calib.json digit/patterns/pattern_00.png "$S/capture_$P/graycode_40.png"; do
  [ -f "$f" ] || { echo "procam_fit_each.sh: $f is missing (run the walk-through's steps 1 first)" >&2; exit 1; }
done
mkdir -p "$D/labels"
others=(); preds=()
for J in 0 1 2; do
  [ "$J" = "$P" ] && continue
  others+=(--scene-for-capture "$J,$D/labels/scene$J.toml")
  preds+=(--predict "$D/labels/scene$J.toml,$S/capture_$J")
done
"$L" scan reconstruct "$S/capture_$P" --calibration digit/calib.json --out "$D/board.ply" \
    --mesh "$D/board-mesh.ply" --black-threshold 3 --white-threshold 1 --fill-holes "$FILL"
"$L" scan label "$D/board-mesh.ply" "$S/capture_$P/graycode_40.png" --calibration digit/calib.json \
    --out "$D/labels/board.ply" --scene "$D/labels/scene$P.toml" --board-capture "$P" \
    --surface-smoothing 100 "${others[@]}" --overlay "$D/labels/overlay.png" --overlay-scale 4 --json > "$D/label.json"
"$L" fit photo "$D/labels/scene$P.toml" --capture "$S/capture_$P" --patterns digit/patterns \
    --fit-frames 0-9,20-29,40,41 --width 320 --height 256 --spp "$SPP" --stride 2 --vignetting \
    "${preds[@]}" ${EXTRA[@]+"${EXTRA[@]}"} --out-dir "$D/fit"
