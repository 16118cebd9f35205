#!/usr/bin/env bash
# How calibrate's cost grows (issue 19): the default run (3 segments + report) on drives of 250 to
# 4000 Pandar64 frames (more figure-8 loops, truncated to the frame count) and on 1000-frame
# drives with sweeps of about 30k, 100k and 250k points (azimuth step 0.75, 0.2, 0.09 deg).
# Wall, CPU and peak RSS from /usr/bin/time -v; also the decode-everything floor (bench/io_floor)
# of each drive, measured right before. Writes WORK_DIR/scaling.csv, prints a Markdown table, and
# draws bench/scaling.svg (bench/plot_scaling.py). Drives are simulated once into WORK_DIR.
#   [BUILD_DIR=build] [TASKSET="taskset -c 0"] [CALIBRATE_ARGS="--config FILE"] [ONLY="f4000 drive"] bash bench/scaling.sh [WORK_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
work=${1:-$(mktemp -d)}
build=${BUILD_DIR:-build}
bin=$build/src/insalign
floor_bin=$build/bench/io_floor
pin=${TASKSET:-}
read -r -a extra <<<"${CALIBRATE_ARGS:-}"  # added to every calibrate run
[[ -x $bin && -x $floor_bin ]] || { echo "scaling.sh: build $bin and $floor_bin first" >&2; exit 2; }
mkdir -p "$work"
# name, then simulate options (seed 11 everywhere: the scene and mount of bench/table1.sh)
drives=(
  "f250 --loops 1 --frames 250"
  "f500 --loops 2 --frames 500"
  "drive"
  "f2000 --loops 6 --frames 2000"
  "f4000 --loops 12 --frames 4000"
  "p30k --azimuth-step-deg 0.75 --frames 1000"
  "p250k --azimuth-step-deg 0.09 --frames 1000"
)
csv=$work/scaling${pin:+-pinned}.csv
echo "drive,frames,points_per_sweep,floor_wall_s,wall_s,cpu_s,peak_mb,sweeps_decoded" >"$csv"
for entry in "${drives[@]}"; do
  read -r name opts <<<"$entry"
  [[ -z ${ONLY:-} || " $ONLY " == *" $name "* ]] || continue
  d=$work/$name
  # shellcheck disable=SC2086
  [[ -f $d/poses.txt ]] || $bin simulate --out "$d" --seed 11 --quiet $opts
  floor=$($floor_bin --lidar-dir "$d/lidar" --json)
  # shellcheck disable=SC2086
  /usr/bin/time -f "%e %U %S %M" -o "$work/$name.time" $pin $bin calibrate --lidar-dir "$d/lidar" \
    --poses "$d/poses.txt" --init "$d/init-extrinsic.json" --fiducials "$d/fiducials.txt" \
    --out "$work/$name-out" "${extra[@]}" >"$work/$name.log" 2>&1
  read -r wall user sys rss <"$work/$name.time"
  frames=$(echo "$floor" | sed -E 's/.*"sweeps": ([0-9]+).*/\1/')
  points=$(echo "$floor" | sed -E 's/.*"points": ([0-9]+).*/\1/')
  floor_wall=$(echo "$floor" | sed -E 's/.*"wall_s": ([0-9.]+).*/\1/')
  decoded=$(sed -n 's/.*; \([0-9]*\) sweeps decoded.*/\1/p' "$work/$name.log")
  echo "$name,$frames,$((points / frames)),$floor_wall,$wall,$(echo "$user + $sys" | bc),$((rss / 1024)),$decoded" >>"$csv"
done
echo "| drive | frames | points per sweep | floor wall s | calibrate wall s | CPU s | ratio to floor | peak RSS MB | sweeps decoded |"
echo "|---|---|---|---|---|---|---|---|---|"
tail -n +2 "$csv" | awk -F, '{printf "| %s | %s | %s | %.2f | %.2f | %.2f | %.2fx | %s | %s |\n", $1, $2, $3, $4, $5, $6, $5 / $4, $7, $8}'
python3 bench/plot_scaling.py "$csv" bench/scaling${pin:+-pinned}.svg
