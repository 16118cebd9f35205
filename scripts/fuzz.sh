#!/usr/bin/env bash
# Builds the libFuzzer harnesses with clang (ASan + UBSan) and runs each for SECONDS (default 60).
#   bash scripts/fuzz.sh [SECONDS]
# Exits non-zero if any harness finds a crash, leak, timeout, out-of-memory or sanitizer report;
# the reproducer is kept in build-fuzz/artifacts/ (replay: build-fuzz/fuzz/fuzz_<parser> FILE).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
bash scripts/install-deps.sh
command -v clang++ >/dev/null || { apt-get install -y -qq clang libclang-rt-dev; }
cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++ \
  -DINSALIGN_FUZZ=ON -DINSALIGN_BUILD_TESTS=OFF >/dev/null
cmake --build build-fuzz --parallel "$(nproc)" --target fuzz_pcd fuzz_poses fuzz_json fuzz_fiducials fuzz_rosbag2 fuzz_ros1_bag fuzz_mcap fuzz_pointcloud2 fuzz_novatel fuzz_sbet fuzz_text_export fuzz_kitti_oxts fuzz_pose_source fuzz_bag_dataset fuzz_manifest fuzz_installed_extrinsic fuzz_check_record
mkdir -p build-fuzz/artifacts
# UBSan findings are recoverable by default; halt so that libFuzzer stops and saves the input.
export UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1
export ASAN_OPTIONS=detect_leaks=1
failed=()
for parser in pcd poses json fiducials rosbag2 ros1_bag mcap pointcloud2 novatel sbet text_export kitti_oxts pose_source bag_dataset manifest installed_extrinsic check_record; do
  work=$(mktemp -d)
  cp fuzz/corpus/$parser/* "$work"/ 2>/dev/null || true
  echo "== fuzz_$parser for ${seconds}s"
  log=build-fuzz/fuzz_$parser.log
  status=0
  build-fuzz/fuzz/fuzz_$parser -max_total_time="$seconds" -max_len=65536 -rss_limit_mb=4096 -timeout=10 \
    -artifact_prefix=build-fuzz/artifacts/"$parser"- -print_final_stats=1 "$work" >"$log" 2>&1 || status=$?
  grep -E "stat::number_of_executed_units|stat::peak_rss" "$log" || true
  if ((status != 0)); then
    failed+=("$parser")
    grep -E -A25 "ERROR|runtime error|SUMMARY" "$log" | head -60 || tail -40 "$log"
  fi
  rm -rf "$work"
done
if ((${#failed[@]})); then
  echo "FAILED: ${failed[*]} (logs in build-fuzz/fuzz_<parser>.log, inputs in build-fuzz/artifacts/)"
  exit 1
fi
echo "all fuzzers clean"
