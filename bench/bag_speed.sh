#!/usr/bin/env bash
# calibrate from a recording vs from the PCD folder of the same simulated drive (issue 15: at most
# 1.2x): the drive is simulated once per container with the same seed (same sweeps, same poses),
# then `calibrate` runs on the PCD folder, an MCAP (zstd chunks), a ROS 1 bag (lz4 chunks) and a
# rosbag2 sqlite3 folder, interleaved REPEAT times; medians of wall time and of CPU time (user +
# sys, less sensitive to a loaded machine) and their ratios to the PCD folder's.
#   [BUILD_DIR=build] [REPEAT=3] [FRAMES=1000] [AZIMUTH_STEP_DEG=0.2] [LIDAR=pandar64] \
#     bash bench/bag_speed.sh [SEED] [WORK_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
seed=${1:-11}
work=${2:-$(mktemp -d)}
build=${BUILD_DIR:-build}
repeat=${REPEAT:-3}
frames=${FRAMES:-1000}
az=${AZIMUTH_STEP_DEG:-0.2}
lidar=${LIDAR:-pandar64}
bin=$build/src/insalign
[[ -x $bin ]] || { echo "bag_speed.sh: $bin not found; build the insalign target first" >&2; exit 2; }
sim() {  # NAME FORMAT
  [[ -f $work/$1/ground_truth.json ]] && return
  echo "simulating $frames frames as $2 into $work/$1 ..." >&2
  $bin simulate --out "$work/$1" --seed "$seed" --frames "$frames" --lidar "$lidar" --azimuth-step-deg "$az" \
    --format "$2" --lidar-convention hesai --ins-message odometry --quiet >/dev/null
}
sim pcd opencalib
sim mcap mcap
sim ros1 ros1
sim db3 db3
input() {  # the input options of one container
  case $1 in
    pcd) echo "--lidar-dir $work/pcd/lidar --poses $work/pcd/poses_tum.txt" ;;  # 100 Hz, as the recordings
    mcap) echo "--bag $work/mcap/drive.mcap" ;;
    ros1) echo "--bag $work/ros1/drive.bag" ;;
    db3) echo "--bag $work/db3/drive" ;;
  esac
}
median() { sort -g | awk '{v[NR] = $1} END {print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2}'; }
for r in $(seq "$repeat"); do
  for c in pcd mcap ros1 db3; do
    # shellcheck disable=SC2046
    /usr/bin/time -f "%e %U %S" -o "$work/$c.time" $bin calibrate $(input $c) --init "$work/$c/init-extrinsic.json" \
      --out "$work/out-$c" --segments 0 --no-report -q >"$work/$c.log" 2>&1 || { cat "$work/$c.log" >&2; exit 1; }
    awk '{printf "%s %.2f\n", $1, $2 + $3}' "$work/$c.time" >>"$work/$c.times"
    echo "run $r $c: $(cat "$work/$c.time")" >&2
  done
done
pcd_wall=$(awk '{print $1}' "$work/pcd.times" | median)
pcd_cpu=$(awk '{print $2}' "$work/pcd.times" | median)
echo "$(date -u +%Y-%m-%d), $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), load $(cut -d' ' -f1 /proc/loadavg)"
echo "drive: seed $seed, $frames frames, $lidar at $az deg; medians of $repeat runs"
echo "| input | wall s | ratio | CPU s | ratio | size |"
echo "|---|---|---|---|---|---|"
for c in pcd mcap ros1 db3; do
  wall=$(awk '{print $1}' "$work/$c.times" | median)
  cpu=$(awk '{print $2}' "$work/$c.times" | median)
  size=$(du -sh "$work/$c" | cut -f1)
  awk -v c="$c" -v w="$wall" -v pw="$pcd_wall" -v u="$cpu" -v pu="$pcd_cpu" -v s="$size" \
    'BEGIN {printf "| %s | %.1f | %.2f | %.1f | %.2f | %s |\n", c, w, w / pw, u, u / pu, s}'
done
