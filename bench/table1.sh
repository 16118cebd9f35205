#!/usr/bin/env bash
# Runtime in the layout of the paper's Table I: seconds per stage of `insalign calibrate` on one
# simulated default drive (about 1000-1200 Pandar64 frames read from PCD files), with and without
# an initial guess, plus the whole run's peak memory. Run it on a quiet machine after a Release
# build (bash scripts/build.sh):
#   bash bench/table1.sh [SEED] [WORK_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
seed=${1:-11}
work=${2:-$(mktemp -d)}
bin=build/src/insalign
[[ -x $bin ]] || { echo "table1.sh: $bin not found; run bash scripts/build.sh first" >&2; exit 2; }
if [[ ! -f $work/drive/poses.txt ]]; then
  echo "simulating seed $seed into $work/drive ..." >&2
  start_ms=$(($(date +%s%N) / 1000000))
  $bin simulate --out "$work/drive" --seed "$seed" --quiet
  echo "simulate: $((($(date +%s%N) / 1000000 - start_ms) / 1000)) s" >&2
fi
d=$work/drive
stage() { sed -n "/^stages/,\$p" "$2" | awk -v s="$1" '$1 == s {print $2; exit}'; }
row() {  # label, log
  local peak
  peak=$(grep -E "^  total " "$2" | sed -E 's/.*peak memory ([0-9]+) MB.*/\1/')
  echo "| $1 | $(stage init "$2") | $(stage rough "$2") | $(stage refine "$2") | $(stage z "$2") | $(stage total "$2") | $peak MB |"
}
sync
$bin calibrate --lidar-dir "$d/lidar" --poses "$d/poses.txt" --init "$d/init-extrinsic.json" \
  --fiducials "$d/fiducials.txt" --out "$work/with-init" --segments 0 --no-report >"$work/with-init.log" 2>&1
$bin calibrate --lidar-dir "$d/lidar" --poses "$d/poses.txt" \
  --fiducials "$d/fiducials.txt" --out "$work/no-init" --segments 0 --no-report >"$work/no-init.log" 2>&1
frames=$(ls "$d/lidar" | wc -l)
echo "Table I layout, seconds (wall): seed $seed, $frames frames, $(nproc) cores, $(lscpu | sed -n 's/^Model name: *//p'), $(date -u +%F)"
echo
echo "| run | start check / init | 1 rough | 2 refine | 3 z | whole run | peak memory |"
echo "|---|---|---|---|---|---|---|"
echo "| paper (i7-8700, 6 cores) | - | 15.85 | | | about 25 | |"
row "insalign, 20 deg / 0.5 m init" "$work/with-init.log"
row "insalign, no init" "$work/no-init.log"
for run in with-init no-init; do
  echo
  echo "$run: $($bin evaluate --gt "$d/ground_truth.json" --result "$work/$run/extrinsic.json" 2>&1 | tr '\n' ' ')"
done
