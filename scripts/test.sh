#!/usr/bin/env bash
# Installs dependencies, builds, and runs the whole test suite.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh -DINSALIGN_BUILD_TESTS=ON
# The fleet tests run against real servers: a single-node Slurm cluster and PostgreSQL, started
# here (as root, without systemd) and stopped on exit; without them those tests skip.
source scripts/fleet-services.sh
if [[ $EUID -eq 0 ]]; then
  trap fleet_services_stop EXIT
  fleet_services_start
else
  echo "not root: the Slurm and PostgreSQL fleet tests will skip"
fi
cd build && ctest --output-on-failure --parallel "$(nproc)" --timeout 900
