#!/usr/bin/env bash
# The engines' overhead against a 3-minute drive's check: ROWS rows that each check the same
# 3-minute drive (a city block, 180 s, Pandar64 at 0.8 deg azimuth, installed extrinsic knocked by
# 0.1 deg of yaw), run directly (xargs -P JOBS), through the local engine and through Slurm, the
# three interleaved in each of ROUNDS rounds so that the machine's load affects all alike.
#   bash bench/fleet_check_overhead.sh [ROWS] [JOBS] [ROUNDS]    (defaults 4, 2, 2; Slurm needs SLURM_CONF or root)
# overhead per task = (engine wall - direct wall) * JOBS / ROWS; share = that / (direct wall * JOBS / ROWS).
# On a shared machine whose load changes between the runs that difference is mostly the load; each
# engine's run is therefore also measured from its own status records (bench/fleet_slots.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
rows=${1:-4}
jobs=${2:-2}
rounds=${3:-2}
exe=${INSALIGN:-$PWD/build/src/insalign}
work=${FLEET_BENCH_DIR:-/tmp/insalign-fleet-check-overhead}
mkdir -p "$work"
drive=$work/drive3min
[[ -f $drive/installed-extrinsic.json ]] ||
  "$exe" simulate --out "$drive" --seed 7 --trajectory city-loop --duration-s 180 --azimuth-step-deg 0.8 --traffic 6 \
    --knock "0 0 0 0 0 0.1" --quiet >/dev/null
manifest=$work/check3min-$rows.csv
echo "car,date,kind,input,extrinsic,options" >"$manifest"
for ((i = 0; i < rows; ++i)); do
  printf 'car%02d,2026-01-01,check,--lidar-dir drive3min/lidar --poses drive3min/poses_tum.txt,drive3min/installed-extrinsic.json,\n' "$i" >>"$manifest"
done
if [[ -z ${SLURM_CONF:-} && $EUID -eq 0 ]]; then
  source scripts/fleet-services.sh
  trap fleet_services_stop EXIT
  fleet_start_slurm
fi
echo "$(lscpu | grep 'Model name' | sed 's/  */ /g'), $(nproc) cores; $(date -u +%FT%TZ); load $(cut -d' ' -f1-3 /proc/loadavg); $(du -sh "$drive" | cut -f1) drive"
now() { date +%s.%N; }
since() { awk -v a="$1" -v b="$(now)" 'BEGIN { print b - a }'; }
share() { awk -v w="$1" -v d="$2" -v j="$jobs" -v n="$rows" 'BEGIN { o = (w - d) * j / n; printf "%+.2f s (%+.1f%%)", o, 100 * o / (d * j / n) }'; }
echo "round  direct_s  local_s  slurm_s  check_s_per_row  local_overhead_per_task  slurm_overhead_per_task"
for ((r = 1; r <= rounds; ++r)); do
  rm -rf "$work/direct" "$work/local" "$work/slurm"
  t0=$(now)
  seq "$rows" | (cd "$work" && xargs -P "$jobs" -I{} "$exe" check --lidar-dir drive3min/lidar --poses drive3min/poses_tum.txt \
    --extrinsic drive3min/installed-extrinsic.json --out "direct/{}" -q >/dev/null 2>&1 || true)
  direct=$(since "$t0")
  t0=$(now)
  "$exe" fleet run "$manifest" --results "$work/local" --jobs "$jobs" >"$work/local.log" || true
  local_s=$(since "$t0")
  slurm_s=nan
  slurm_o=nan
  if sinfo -h >/dev/null 2>&1; then
    t0=$(now)
    "$exe" fleet run "$manifest" --results "$work/slurm" --engine slurm --wait --jobs "$jobs" --cpus-per-task 1 --poll-s 0.2 \
      >"$work/slurm.log" || true
    slurm_s=$(since "$t0")
    slurm_o=$(share "$slurm_s" "$direct")
  fi
  printf "%5d  %8.1f  %7.1f  %7s  %15.1f  %23s  %23s\n" "$r" "$direct" "$local_s" "$slurm_s" \
    "$(awk -v d="$direct" -v j="$jobs" -v n="$rows" 'BEGIN { print d * j / n }')" "$(share "$local_s" "$direct")" "$slurm_o"
  grep -hE '^[0-9]+ rows' "$work/local.log" "$work/slurm.log" 2>/dev/null | sed 's/^/       /'
  for e in local slurm; do [[ -d $work/$e ]] && bash bench/fleet_slots.sh "$work/$e" "$jobs" | sed 's/^/       /'; done
done
