#!/usr/bin/env bash
# The engines' overhead per task, apart from the work: ROWS rows whose command fails at once (a
# missing recording, exit 2 in milliseconds) through each engine and directly (xargs -P), ROUNDS
# rounds interleaved so that the machine's load affects all alike.
#   bash bench/fleet_overhead.sh [ROWS] [JOBS] [ROUNDS]     (defaults 100, 2, 3; Slurm needs SLURM_CONF or root)
# overhead per task = (engine wall - direct wall) * JOBS / ROWS
set -euo pipefail
cd "$(dirname "$0")/.."
rows=${1:-100}
jobs=${2:-2}
rounds=${3:-3}
exe=${INSALIGN:-$PWD/build/src/insalign}
work=${FLEET_BENCH_DIR:-/tmp/insalign-fleet-overhead}
rm -rf "$work"
mkdir -p "$work"
manifest=$work/noop-$rows.csv
echo "car,date,kind,input,extrinsic,options" >"$manifest"
for ((i = 0; i < rows; ++i)); do
  printf 'car%03d,2026-01-%02d,calibrate,--lidar-dir missing/lidar --poses missing/poses.txt,,\n' $((i / 10)) $((i % 10 + 1)) >>"$manifest"
done
if [[ -z ${SLURM_CONF:-} && $EUID -eq 0 ]]; then
  source scripts/fleet-services.sh
  trap fleet_services_stop EXIT
  fleet_start_slurm
fi
now() { date +%s.%N; }
since() { awk -v a="$1" -v b="$(now)" 'BEGIN { print b - a }'; }
overhead() { awk -v w="$1" -v d="$2" -v j="$jobs" -v n="$rows" 'BEGIN { printf "%.3f", (w - d) * j / n }'; }
echo "round  direct_s  local_s  slurm_s  local_overhead_s_per_task  slurm_overhead_s_per_task"
for ((r = 1; r <= rounds; ++r)); do
  t0=$(now)
  seq "$rows" | (cd "$work" && xargs -P "$jobs" -I{} "$exe" calibrate --lidar-dir missing/lidar --poses missing/poses.txt \
    --out "direct/{}" >/dev/null 2>&1 || true)
  direct=$(since "$t0")
  rm -rf "$work/local"
  t0=$(now)
  "$exe" fleet run "$manifest" --results "$work/local" --jobs "$jobs" >/dev/null || true
  local_s=$(since "$t0")
  slurm_s=nan
  slurm_o=nan
  if sinfo -h >/dev/null 2>&1; then
    rm -rf "$work/slurm"
    t0=$(now)
    "$exe" fleet run "$manifest" --results "$work/slurm" --engine slurm --wait --jobs "$jobs" --cpus-per-task 1 --poll-s 0.2 \
      >"$work/slurm.log" || true
    slurm_s=$(since "$t0")
    slurm_o=$(overhead "$slurm_s" "$direct")
  fi
  printf "%5d  %8.2f  %7.2f  %7s  %25s  %25s\n" "$r" "$direct" "$local_s" "$slurm_s" "$(overhead "$local_s" "$direct")" "$slurm_o"
  for e in local slurm; do [[ -d $work/$e ]] && bash bench/fleet_slots.sh "$work/$e" "$jobs" | sed 's/^/       /'; done
done
