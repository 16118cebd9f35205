#!/usr/bin/env bash
# calibrate from a recording vs from the PCD folder of the same simulated drive (issue 41: at most
# 1.1x): the drive is simulated once per container with the same seed (same sweeps, same poses),
# written as the recorders write it at their default chunk sizes: MCAP zstd and lz4 as
# `ros2 bag record` does (768 KiB chunks holding clouds and INS messages in time order:
# --bag-chunking recorder), rosbag2 sqlite3 (one row per message), ROS 1 lz4 and bz2 as
# `rosbag record -j/--lz4` (768 KiB chunks). Then `calibrate` runs on the PCD folder and on each
# recording, interleaved REPEAT times (pcd, mcap-zstd, ..., pcd, mcap-zstd, ...); medians of wall
# time, of CPU time (user + sys, less sensitive to a loaded machine), of peak RSS and of the peak
# of the anonymous (heap) memory (RssAnon in /proc/PID/status, sampled every 0.1 s: peak RSS also
# counts the pages of a file the reader maps, as the sqlite3 reader maps its .db3), and the ratios
# to the PCD folder's. BIN=path/to/insalign times another binary (a build of main: "before").
#   [BUILD_DIR=build] [REPEAT=3] [FRAMES=1000] [AZIMUTH_STEP_DEG=0.2] [LIDAR=pandar64] \
#     [CONTAINERS="mcap-zstd mcap-lz4 db3 ros1-lz4 ros1-bz2"] [SIM_ONLY=0] bash bench/bag_speed.sh [SEED] [WORK_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
seed=${1:-11}
work=${2:-$(mktemp -d)}
build=${BUILD_DIR:-build}
repeat=${REPEAT:-3}
frames=${FRAMES:-1000}
az=${AZIMUTH_STEP_DEG:-0.2}
lidar=${LIDAR:-pandar64}
containers=${CONTAINERS:-mcap-zstd mcap-lz4 db3 ros1-lz4 ros1-bz2}
bin=${BIN:-$build/src/insalign}
[[ -x $bin ]] || { echo "bag_speed.sh: $bin not found; build the insalign target first" >&2; exit 2; }
sim() {  # NAME FORMAT [more simulate options]
  local name=$1 format=$2
  shift 2
  [[ -f $work/$name/ground_truth.json ]] && return
  echo "simulating $frames frames as $name into $work/$name ..." >&2
  $bin simulate --out "$work/$name" --seed "$seed" --frames "$frames" --lidar "$lidar" --azimuth-step-deg "$az" \
    --format "$format" "$@" --lidar-convention hesai --ins-message odometry --quiet >/dev/null
}
sim pcd opencalib
for c in $containers; do
  case $c in
    mcap-zstd) sim "$c" mcap --bag-compression zstd --bag-chunking recorder ;;
    mcap-lz4) sim "$c" mcap --bag-compression lz4 --bag-chunking recorder ;;
    db3) sim "$c" db3 ;;
    ros1-lz4) sim "$c" ros1 --bag-compression lz4 ;;
    ros1-bz2) sim "$c" ros1 --bag-compression bz2 ;;
    *) echo "bag_speed.sh: unknown container $c" >&2; exit 2 ;;
  esac
done
[[ ${SIM_ONLY:-0} == 1 ]] && exit 0
input() {  # the input options of one container
  case $1 in
    pcd) echo "--lidar-dir $work/pcd/lidar --poses $work/pcd/poses_tum.txt" ;;  # 100 Hz, as the recordings
    mcap-*) echo "--bag $work/$1/drive.mcap" ;;
    ros1-*) echo "--bag $work/$1/drive.bag" ;;
    db3) echo "--bag $work/db3/drive" ;;
  esac
}
# One calibrate under /usr/bin/time (to $work/$c.time); prints the peak RssAnon (kB) sampled meanwhile.
timed_run() {  # CONTAINER
  local c=$1 peak=0 child anon
  # shellcheck disable=SC2046
  /usr/bin/time -f "%e %U %S %M" -o "$work/$c.time" $bin calibrate $(input "$c") --init "$work/$c/init-extrinsic.json" \
    --out "$work/out-$c" --segments 0 --no-report -q >"$work/$c.log" 2>&1 &
  local timer=$!
  while kill -0 "$timer" 2>/dev/null; do
    child=$(pgrep -P "$timer" | head -1 || true)
    if [[ -n $child ]]; then
      anon=$(awk '/^RssAnon:/ {print $2}' "/proc/$child/status" 2>/dev/null || true)
      [[ -n $anon && $anon -gt $peak ]] && peak=$anon
    fi
    sleep 0.1
  done
  wait "$timer" || { cat "$work/$c.log" >&2; exit 1; }
  echo "$peak"
}
median() { sort -g | awk '{v[NR] = $1} END {print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2}'; }
all="pcd $containers"
for c in $all; do rm -f "$work/$c.times"; done
for r in $(seq "$repeat"); do
  for c in $all; do
    anon=$(timed_run "$c")
    awk -v a="$anon" '{printf "%s %.2f %d %d\n", $1, $2 + $3, $4, a}' "$work/$c.time" >>"$work/$c.times"
    echo "run $r $c: $(cat "$work/$c.time") anon ${anon} kB" >&2
  done
done
pcd_wall=$(awk '{print $1}' "$work/pcd.times" | median)
pcd_cpu=$(awk '{print $2}' "$work/pcd.times" | median)
echo "$(date -u +%Y-%m-%d), $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), load $(cut -d' ' -f1 /proc/loadavg)"
echo "drive: seed $seed, $frames frames, $lidar at $az deg; medians of $repeat interleaved runs"
echo "| input | wall s | ratio | CPU s | ratio | peak RSS MB | peak anon MB | size |"
echo "|---|---|---|---|---|---|---|---|"
for c in $all; do
  wall=$(awk '{print $1}' "$work/$c.times" | median)
  cpu=$(awk '{print $2}' "$work/$c.times" | median)
  rss=$(awk '{print $3}' "$work/$c.times" | median)
  anon=$(awk '{print $4}' "$work/$c.times" | median)
  size=$(du -shL "$work/$c" | cut -f1)
  awk -v c="$c" -v w="$wall" -v pw="$pcd_wall" -v u="$cpu" -v pu="$pcd_cpu" -v m="$rss" -v a="$anon" -v s="$size" \
    'BEGIN {printf "| %s | %.2f | %.2f | %.2f | %.2f | %.0f | %.0f | %s |\n", c, w, w / pw, u, u / pu, m / 1024, a / 1024, s}'
done
