#!/usr/bin/env bash
# A four-LiDAR rig against its roof LiDAR alone (issue 41, point 2): the default `calibrate`
# (3 segments, report) on the rig of docs/rigs.md and on its roof LiDAR, interleaved, for one or
# two builds (BEFORE: another build's insalign, e.g. main's; or BEFORE_ARGS alone: this build with
# those arguments, e.g. the --set switches that restore an earlier behaviour), REPEAT rounds in the order
# rig-after rig-before roof-after roof-off (trajectory.mode=off) roof-before. Prints one line per run: label, wall s, CPU s
# (user + sys), peak RSS MB; then the medians. The drive is simulated once into WORK_DIR (3.6 GB).
#   [BUILD_DIR=build] [BEFORE=/work/main/build/src/insalign] [REPEAT=3] [SIM_ARGS="--seed 1"] \
#     [CALIBRATE_ARGS="-q"] bash bench/rig_speed.sh WORK_DIR
set -euo pipefail
cd "$(dirname "$0")/.."
work=${1:?WORK_DIR}
bin=$(realpath "${BUILD_DIR:-build}/src/insalign")
before=${BEFORE:-}
read -r -a before_args <<<"${BEFORE_ARGS:-}"
[[ -n $before || ${#before_args[@]} -eq 0 ]] || before=$bin
repeat=${REPEAT:-3}
read -r -a sim <<<"${SIM_ARGS:---seed 1}"
read -r -a extra <<<"${CALIBRATE_ARGS:--q}"
rig=top:pandar64,left:vlp16@left,right:vlp16@right,front:os1-64@front
d=$work/rig
mkdir -p "$work"
[[ -f $d/poses_tum.txt ]] || "$bin" simulate --out "$d" --rig "$rig" --quiet "${sim[@]}"
names=(top left right front)
rig_args=()
for n in "${names[@]}"; do rig_args+=(--lidar-dir "$d/lidar/$n"); done
for n in "${names[@]}"; do rig_args+=(--init "$d/init-extrinsic-$n.json"); done
roof_args=(--lidar-dir "$d/lidar/top" --init "$d/init-extrinsic-top.json")
common=(--poses "$d/poses_tum.txt" --fiducials "$d/fiducials.txt")
times=$work/rig_speed.txt
: >"$times"
run() {  # label binary args...
  local label=$1 b=$2
  shift 2
  /usr/bin/time -f "%e %U %S %M" -o "$work/$label.time" "$b" calibrate "$@" "${common[@]}" --out "$work/$label" \
    "${extra[@]}" >"$work/$label.log" 2>&1
  read -r wall user sys rss <"$work/$label.time"
  echo "$label $wall $(echo "$user + $sys" | bc) $((rss / 1024))" | tee -a "$times"
}
echo "# $(lscpu | sed -n 's/^Model name: *//p'), $(nproc) cores, $(date -u '+%F %H:%M UTC'), load $(cut -d' ' -f1-3 /proc/loadavg)"
for ((r = 0; r < repeat; ++r)); do
  run rig-after "$bin" "${rig_args[@]}"
  [[ -z $before ]] || run rig-before "$before" "${rig_args[@]}" "${before_args[@]}"
  run roof-after "$bin" "${roof_args[@]}"
  # Both estimate the INS trajectory correction wherever the map offsets say the INS may drift
  # (a TUM pose file states no accuracy; the rig with its reference LiDAR): the roof without it too.
  run roof-off "$bin" "${roof_args[@]}" --set trajectory.mode=off
  [[ -z $before ]] || run roof-before "$before" "${roof_args[@]}" "${before_args[@]}"
done
echo "# load at the end $(cut -d' ' -f1-3 /proc/loadavg); medians: label wall_s cpu_s peak_mb"
for label in rig-after rig-before roof-after roof-off roof-before; do
  grep -q "^$label " "$times" || continue
  med() { grep "^$label " "$times" | awk -v c="$1" '{print $c}' | sort -g |
    awk '{v[NR] = $1} END {print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2}'; }
  echo "$label $(med 2) $(med 3) $(med 4)"
done
