#!/usr/bin/env bash
# Builds the libFuzzer harnesses with clang (ASan + UBSan) and runs each for SECONDS (default 60).
#   bash scripts/fuzz.sh [SECONDS]
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
bash scripts/install-deps.sh
command -v clang++ >/dev/null || { apt-get install -y -qq clang libclang-rt-dev; }
cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++ \
  -DINSALIGN_FUZZ=ON -DINSALIGN_BUILD_TESTS=OFF >/dev/null
cmake --build build-fuzz --parallel "$(nproc)" --target fuzz_pcd fuzz_poses fuzz_json fuzz_fiducials
for parser in pcd poses json fiducials; do
  work=$(mktemp -d)
  cp fuzz/corpus/$parser/* "$work"/ 2>/dev/null || true
  echo "== fuzz_$parser for ${seconds}s"
  build-fuzz/fuzz/fuzz_$parser -max_total_time="$seconds" -max_len=65536 -rss_limit_mb=4096 \
    -print_final_stats=1 "$work" 2>&1 | grep -E "stat::number_of_executed_units|stat::peak_rss|ERROR|SUMMARY|crash" || true
  rm -rf "$work"
done
