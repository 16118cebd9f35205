#!/usr/bin/env bash
# Fleet throughput: rows per hour on this machine with the local engine and with Slurm, against
# the same commands run directly (xargs -P, no engine), and the engine's overhead per task.
#   bash bench/fleet.sh [ROWS] [JOBS]      (defaults 100 rows, 2 jobs; as root for Slurm)
# Rows are short simulated drives (VLP-16 at 1 deg, 120 frames = 12 s), four recordings shared by the rows.
# Also times a 3-minute drive's calibration (the unit the overhead is compared with).
set -euo pipefail
cd "$(dirname "$0")/.."
rows=${1:-100}
jobs=${2:-2}
exe=$PWD/build/src/insalign
work=${FLEET_BENCH_DIR:-/tmp/insalign-fleet-bench}
mkdir -p "$work"
for s in 1 2 3 4; do
  [[ -f $work/d$s/ground_truth.json ]] ||
    "$exe" simulate --out "$work/d$s" --seed "$s" --loops 1 --frames 120 --lidar vlp16 --azimuth-step-deg 1 --quiet >/dev/null
done
manifest=$work/fleet-$rows.csv
echo "car,date,kind,input,extrinsic,options" >"$manifest"
for ((i = 0; i < rows; ++i)); do
  d=d$((i % 4 + 1))
  printf 'car%03d,2026-01-%02d,calibrate,--lidar-dir %s/lidar --poses %s/poses.txt,,"--init %s/init-extrinsic.json --fiducials %s/fiducials.txt"\n' \
    $((i / 10)) $((i % 10 + 1)) $d $d $d $d >>"$manifest"
done

now() { date +%s.%N; }
report() { awk -v n="$rows" -v w="$2" -v j="$jobs" -v base="${3:-0}" -v name="$1" 'BEGIN {
  printf "%-8s %5d rows  %8.1f s  %7.0f rows/h", name, n, w, n * 3600 / w;
  if (base > 0) printf "  overhead %+.3f s per task (x%d jobs / rows)", (w - base) * j / n, j;
  printf "\n" }'; }

# Direct: the same calibrate commands, JOBS at a time, no engine, no status records.
rm -rf "$work/direct"
mkdir -p "$work/direct"
t0=$(now)
tail -n +2 "$manifest" | awk -F, '{ print NR }' | (cd "$work" && xargs -P "$jobs" -I{} sh -c \
  'd=d$(( ({} - 1) % 4 + 1 )); '"$exe"' calibrate --lidar-dir $d/lidar --poses $d/poses.txt --init $d/init-extrinsic.json --fiducials $d/fiducials.txt --out direct/{} >/dev/null 2>&1 || true')
direct=$(awk -v a="$t0" -v b="$(now)" 'BEGIN { print b - a }')
report direct "$direct"
echo "direct: $(find "$work/direct" -name extrinsic.json | wc -l) of $rows rows wrote extrinsic.json"

rm -rf "$work/local"
t0=$(now)
"$exe" fleet run "$manifest" --results "$work/local" --jobs "$jobs" >"$work/local.log" || true
grep -E '^[0-9]+ rows' "$work/local.log"
local_s=$(awk -v a="$t0" -v b="$(now)" 'BEGIN { print b - a }')
report local "$local_s" "$direct"

if [[ -z ${SLURM_CONF:-} && $EUID -eq 0 ]]; then
  source scripts/fleet-services.sh
  trap fleet_services_stop EXIT
  fleet_start_slurm
fi
if sinfo -h >/dev/null 2>&1; then
  rm -rf "$work/slurm"
  t0=$(now)
  "$exe" fleet run "$manifest" --results "$work/slurm" --engine slurm --wait --jobs "$jobs" --cpus-per-task 1 --poll-s 1 \
    >"$work/slurm.log" || true
  grep -E '^[0-9]+ rows' "$work/slurm.log"
  slurm_s=$(awk -v a="$t0" -v b="$(now)" 'BEGIN { print b - a }')
  report slurm "$slurm_s" "$direct"
fi

# A 3-minute drive (Pandar64, the simulator's default LiDAR): the check/calibration the overhead is compared with.
[[ -f $work/drive3min/ground_truth.json ]] || "$exe" simulate --out "$work/drive3min" --seed 7 --duration-s 180 --quiet >/dev/null
t0=$(now)
"$exe" calibrate --lidar-dir "$work/drive3min/lidar" --poses "$work/drive3min/poses.txt" --init "$work/drive3min/init-extrinsic.json" \
  --fiducials "$work/drive3min/fiducials.txt" --out "$work/drive3min-result" >/dev/null 2>&1 || true
echo "3-minute drive: calibrate $(awk -v a="$t0" -v b="$(now)" 'BEGIN { printf "%.1f", b - a }') s"
