#!/usr/bin/env bash
# A 10-minute drive's check against the decode-every-sweep floor (issue 38, point 5): `insalign
# check` on a simulated 600 s city loop (6000 sweeps, traffic) and `io_floor` (every sweep decoded
# once, one thread), interleaved REPEAT rounds. Prints one line per run: label, wall s, CPU s
# (user + sys), peak RSS MB, and for the check the sweeps it decoded; then the medians.
# AZIMUTH: the LiDAR's horizontal step (0.2 deg: the Pandar64's own, ~110k points per sweep, about
# 9 GB of PCD; 0.8: a quarter of the points, 2.3 GB). The drive is simulated once into WORK_DIR.
#   [BUILD_DIR=build] [REPEAT=2] [AZIMUTH=0.2] bash bench/check_long.sh WORK_DIR
set -euo pipefail
cd "$(dirname "$0")/.."
work=${1:?WORK_DIR}
build=$(realpath "${BUILD_DIR:-build}")
bin=$build/src/insalign
floor=$build/bench/io_floor
repeat=${REPEAT:-2}
azimuth=${AZIMUTH:-0.2}
d=$work/long-$azimuth
mkdir -p "$work"
[[ -f $d/poses_tum.txt ]] || "$bin" simulate --out "$d" --seed 11 --trajectory city-loop --duration-s 600 \
  --lidar pandar64 --azimuth-step-deg "$azimuth" --traffic 10 --quiet
times=$work/check_long-$azimuth.txt
: >"$times"
measure() {  # label command...
  local label=$1
  shift
  /usr/bin/time -f "%e %U %S %M" -o "$work/$label.time" "$@" >"$work/$label.log" 2>&1 || true
  read -r wall user sys rss < <(tail -n 1 "$work/$label.time")  # after "Command exited with non-zero status 3"
  local decoded=""
  [[ $label != check* ]] || decoded=$(jq -r '"\(.frames_decoded) of \(.frames_total)"' "$work/chk/check.json" 2>/dev/null || echo "?")
  echo "$label $wall $(echo "$user + $sys" | bc) $((rss / 1024)) $decoded" | tee -a "$times"
}
echo "# $(lscpu | sed -n 's/^Model name: *//p'), $(nproc) cores, $(date -u '+%F %H:%M UTC'), load $(cut -d' ' -f1-3 /proc/loadavg), azimuth $azimuth deg"
for ((r = 0; r < repeat; ++r)); do
  rm -rf "$work/chk"
  measure check "$bin" check -q --lidar-dir "$d/lidar" --poses "$d/poses_tum.txt" \
    --extrinsic "$d/installed-extrinsic.json" --out "$work/chk"
  measure io_floor "$floor" --lidar-dir "$d/lidar"
done
echo "# load at the end $(cut -d' ' -f1-3 /proc/loadavg); medians: label wall_s cpu_s peak_mb"
for label in check io_floor; do
  med() { grep "^$label " "$times" | awk -v c="$1" '{print $c}' | sort -g |
    awk '{v[NR] = $1} END {print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2}'; }
  echo "$label $(med 2) $(med 3) $(med 4)"
done
