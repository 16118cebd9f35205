#!/usr/bin/env bash
# Installs what insalign needs to build and test on Debian 12 (run as root; apt-get only).
set -euo pipefail
export DEBIAN_FRONTEND=noninteractive
packages=(
  build-essential cmake ninja-build pkg-config git
  libeigen3-dev libtbb-dev libnanoflann-dev
  nlohmann-json3-dev libyaml-cpp-dev libcli11-dev libfmt-dev liblzf-dev libstb-dev libpng-dev
  libbz2-dev liblz4-dev libzstd-dev libsqlite3-dev libgeographiclib-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  chromium  # headless, for the report rendering test
  libpq-dev  # fleets: the PostgreSQL history database
  slurm-wlm munge postgresql  # fleets: the test suite runs a single-node Slurm cluster and a PostgreSQL server
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
