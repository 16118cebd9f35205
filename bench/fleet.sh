#!/usr/bin/env bash
# Fleet throughput: rows per hour on this machine with the local engine and with Slurm, against
# the same `insalign check` commands run directly (xargs -P, no engine, no status records).
#   bash bench/fleet.sh [ROWS] [JOBS] [MODES]    (defaults 100, 2, "direct local slurm"; Slurm needs SLURM_CONF or root)
# Rows are `check` rows of tiny simulated ordinary drives (a city block, 5 s, VLP-16 at 2 deg,
# about 0.6 CPU-s each), four recordings shared by the rows. INSALIGN=path picks the binary
# (default build/src/insalign). Prints one line per mode: wall, CPU (user+sys of the processes
# this script waits for; Slurm's tasks run under slurmd and are not counted), rows per hour, and
# with direct the overhead per task = (engine wall - direct wall) * JOBS / ROWS, and for each
# engine the slots' idle time per row from its own status records (bench/fleet_slots.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
rows=${1:-100}
jobs=${2:-2}
modes=${3:-direct local slurm}
exe=${INSALIGN:-$PWD/build/src/insalign}
work=${FLEET_BENCH_DIR:-/tmp/insalign-fleet-bench}
mkdir -p "$work"
for s in 1 2 3 4; do
  [[ -f $work/d$s/installed-extrinsic.json ]] ||
    "$exe" simulate --out "$work/d$s" --seed "$s" --trajectory city-loop --duration-s 5 --lidar vlp16 --azimuth-step-deg 2 \
      --extrinsic "0.8 -0.2 1.7 0.5 -1 2" --quiet >/dev/null
done
manifest=$work/fleet-$rows.csv
echo "car,date,kind,input,extrinsic,options" >"$manifest"
for ((i = 0; i < rows; ++i)); do
  d=d$((i % 4 + 1))
  printf 'car%04d,2026-01-%02d,check,--lidar-dir %s/lidar --poses %s/poses_tum.txt,%s/installed-extrinsic.json,\n' \
    $((i / 10)) $((i % 10 + 1)) $d $d $d >>"$manifest"
done
if [[ $modes == *slurm* && -z ${SLURM_CONF:-} && $EUID -eq 0 ]]; then
  source scripts/fleet-services.sh
  trap fleet_services_stop EXIT
  fleet_start_slurm
fi

echo "$(lscpu | grep 'Model name' | sed 's/  */ /g'), $(nproc) cores; $(date -u +%FT%TZ); load $(cut -d' ' -f1-3 /proc/loadavg)"
direct=0
# mode wall cpu done
report() {
  awk -v m="$1" -v n="$rows" -v w="$2" -v c="$3" -v d="$4" -v j="$jobs" -v base="$direct" 'BEGIN {
    printf "%-7s %5d rows (%s done)  wall %8.1f s  cpu %8.1f s  %7.0f rows/h", m, n, d, w, c, n * 3600 / w;
    if (base > 0 && m != "direct") printf "  overhead %+.3f s per task", (w - base) * j / n;
    printf "\n" }'
}
timed() {  # runs "$@" under /usr/bin/time; sets wall and cpu
  /usr/bin/time -f "%e %U %S" -o "$work/time" "$@" || true
  read -r wall user sys <"$work/time"
  cpu=$(awk -v u="$user" -v s="$sys" 'BEGIN { print u + s }')
}
for mode in $modes; do
  rm -rf "$work/$mode"
  case $mode in
    direct)
      mkdir -p "$work/direct"
      timed sh -c "tail -n +2 '$manifest' | awk '{ print NR }' | (cd '$work' && xargs -P '$jobs' -I{} sh -c \
        'd=d\$(( ({} - 1) % 4 + 1 )); \"$exe\" check --lidar-dir \$d/lidar --poses \$d/poses_tum.txt \
         --extrinsic \$d/installed-extrinsic.json --out direct/{} -q >/dev/null 2>&1; true')"
      done_rows=$(find "$work/direct" -name check.json | wc -l)
      direct=$wall ;;
    local)
      timed "$exe" fleet run "$manifest" --results "$work/local" --jobs "$jobs" >"$work/local.log"
      done_rows=$(grep -oE '[0-9]+ done' "$work/local.log" | head -1) ;;
    slurm)
      sinfo -h >/dev/null 2>&1 || { echo "slurm: no cluster (sinfo failed)"; continue; }
      timed "$exe" fleet run "$manifest" --results "$work/slurm" --engine slurm --wait --jobs "$jobs" --cpus-per-task 1 \
        --poll-s 1 >"$work/slurm.log"
      done_rows=$(grep -oE '[0-9]+ done' "$work/slurm.log" | head -1) ;;
  esac
  report "$mode" "$wall" "$cpu" "${done_rows% done}"
  [[ $mode == direct ]] || bash bench/fleet_slots.sh "$work/$mode" "$jobs"
done
