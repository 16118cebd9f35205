#!/usr/bin/env bash
# Runtime in the layout of the paper's Table I: seconds per stage of `insalign calibrate` on one
# simulated default drive (about 1000-1200 Pandar64 frames read from PCD files), with and without
# an initial guess, plus the whole run's peak memory. Then calibrate's wall time as a ratio to the
# decode-everything floor (bench/io_floor: every sweep decoded once, one thread), measured in the
# same run: floor and calibrate back to back, REPEAT times, medians. Run it after a Release build
# with the benchmarks (bash scripts/build.sh, or any build folder with -DINSALIGN_BUILD_BENCH=ON):
#   [BUILD_DIR=build] [REPEAT=3] [CALIBRATE_ARGS="--config FILE"] bash bench/table1.sh [SEED] [WORK_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
seed=${1:-11}
work=${2:-$(mktemp -d)}
build=${BUILD_DIR:-build}
repeat=${REPEAT:-3}
read -r -a extra <<<"${CALIBRATE_ARGS:-}"  # added to every calibrate run
bin=$build/src/insalign
floor_bin=$build/bench/io_floor
[[ -x $bin ]] || { echo "table1.sh: $bin not found; run bash scripts/build.sh first" >&2; exit 2; }
[[ -x $floor_bin ]] || { echo "table1.sh: $floor_bin not found; build with -DINSALIGN_BUILD_BENCH=ON" >&2; exit 2; }
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
median() { sort -g | awk '{v[NR] = $1} END {print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2}'; }
# timed LABEL ARGS...: one calibrate run; appends "wall_s peak_mb" to $work/LABEL.times
timed() {
  local label=$1
  shift
  /usr/bin/time -f "%e %M" -o "$work/$label.time" $bin calibrate --lidar-dir "$d/lidar" --poses "$d/poses.txt" \
    --init "$d/init-extrinsic.json" --fiducials "$d/fiducials.txt" --out "$work/$label" "${extra[@]}" "$@" >"$work/$label.log" 2>&1
  awk '{printf "%s %.0f\n", $1, $2 / 1024}' "$work/$label.time" >>"$work/$label.times"
}
sync
$bin calibrate --lidar-dir "$d/lidar" --poses "$d/poses.txt" --init "$d/init-extrinsic.json" \
  --fiducials "$d/fiducials.txt" --out "$work/with-init" "${extra[@]}" --segments 0 --no-report >"$work/with-init.log" 2>&1
$bin calibrate --lidar-dir "$d/lidar" --poses "$d/poses.txt" \
  --fiducials "$d/fiducials.txt" --out "$work/no-init" "${extra[@]}" --segments 0 --no-report >"$work/no-init.log" 2>&1
rm -f "$work"/floor.times "$work"/default.times "$work"/stages.times
for ((r = 0; r < repeat; ++r)); do
  "$floor_bin" --lidar-dir "$d/lidar" --json | sed -E 's/.*"wall_s": ([0-9.]+).*/\1/' >>"$work/floor.times"
  timed default
  timed stages --segments 0 --no-report
done
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
echo
echo "Against the decode-everything floor ($floor_bin, one thread), $repeat rounds of floor + default +"
echo "stages-only back to back; medians; ratio = median over the rounds of calibrate / that round's floor."
echo "Process wall time (loading included) and peak RSS from /usr/bin/time."
echo
echo "| run | calibrate wall s | floor wall s | ratio to the floor | peak RSS MB | wall s of each round |"
echo "|---|---|---|---|---|---|"
floor_med=$(median <"$work/floor.times")
for label in default stages; do
  ratio=$(paste -d' ' "$work/$label.times" "$work/floor.times" | awk '{print $1 / $3}' | median)
  wall=$(awk '{print $1}' "$work/$label.times" | median)
  peak=$(awk '{print $2}' "$work/$label.times" | sort -n | tail -1)
  name=$([[ $label == default ]] && echo "default (3 segments + report)" || echo "--segments 0 --no-report")
  echo "| $name | $wall | $floor_med | $(printf '%.2f' "$ratio")x | $peak | $(awk '{print $1}' "$work/$label.times" | tr '\n' ' ') |"
done
