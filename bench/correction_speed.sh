#!/usr/bin/env bash
# The default run with the INS trajectory correction against `trajectory.mode=off` (issue 41,
# point 3): `calibrate` on a simulated drifting drive (1000 Pandar64 sweeps at full resolution,
# `--ins-error drift`, where the default engages the correction), interleaved REPEAT rounds in the
# order off, default. Prints one line per run: label, wall s, CPU s (user + sys), peak RSS MB,
# whether the correction was applied; then the medians and the ratio of the medians.
#   [BUILD_DIR=build] [REPEAT=5] [SIM_ARGS="--seed 11 --frames 1000 --ins-error drift"] \
#     bash bench/correction_speed.sh WORK_DIR
set -euo pipefail
cd "$(dirname "$0")/.."
work=${1:?WORK_DIR}
bin=$(realpath "${BUILD_DIR:-build}/src/insalign")
repeat=${REPEAT:-5}
read -r -a sim <<<"${SIM_ARGS:---seed 11 --frames 1000 --ins-error drift}"
d=$work/drift
mkdir -p "$work"
[[ -f $d/poses_tum.txt ]] || "$bin" simulate --out "$d" --azimuth-step-deg 0.2 --quiet "${sim[@]}"
times=$work/correction_speed.txt
: >"$times"
run() {  # label extra-args...
  local label=$1
  shift
  rm -rf "$work/$label"
  /usr/bin/time -f "%e %U %S %M" -o "$work/$label.time" "$bin" calibrate -q --lidar-dir "$d/lidar" \
    --poses "$d/poses_tum.txt" --fiducials "$d/fiducials.txt" --out "$work/$label" "$@" >"$work/$label.log" 2>&1
  read -r wall user sys rss <"$work/$label.time"
  local applied
  applied=$(jq -r '.trajectory_correction.applied' "$work/$label/extrinsic.json")
  echo "$label $wall $(echo "$user + $sys" | bc) $((rss / 1024)) applied=$applied" | tee -a "$times"
}
echo "# $(lscpu | sed -n 's/^Model name: *//p'), $(nproc) cores, $(date -u '+%F %H:%M UTC'), load $(cut -d' ' -f1-3 /proc/loadavg), $(git rev-parse --short HEAD)"
for ((r = 0; r < repeat; ++r)); do
  run off --set trajectory.mode=off
  run default
done
echo "# load at the end $(cut -d' ' -f1-3 /proc/loadavg); medians: label wall_s cpu_s peak_mb"
med() {  # label column
  grep "^$1 " "$times" | awk -v c="$2" '{print $c}' | sort -g |
    awk '{v[NR] = $1} END {print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2}'
}
for label in off default; do echo "$label $(med "$label" 2) $(med "$label" 3) $(med "$label" 4)"; done
echo "ratio default/off: wall $(echo "scale=3; $(med default 2) / $(med off 2)" | bc), CPU $(echo "scale=3; $(med default 3) / $(med off 3)" | bc)"
