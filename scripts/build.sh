#!/usr/bin/env bash
# Configures and builds insalign (Release) into build/.
# Arguments go to cmake's configure step; INSALIGN_TARGETS (space-separated) builds only those
# targets (the demo builds the tool alone; empty builds everything, the tests included).
set -euo pipefail
cd "$(dirname "$0")/.."
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release "$@" >/dev/null
targets=()
for t in ${INSALIGN_TARGETS:-}; do targets+=(--target "$t"); done
cmake --build build --parallel "$(nproc)" "${targets[@]}"
