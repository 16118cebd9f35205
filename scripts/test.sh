#!/usr/bin/env bash
# Installs dependencies, builds, and runs the whole test suite.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh -DINSALIGN_BUILD_TESTS=ON
cd build && ctest --output-on-failure --parallel "$(nproc)" --timeout 900
