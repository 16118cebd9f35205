#!/usr/bin/env bash
# The main job on the built-in default: simulate a figure-8 drive, calibrate it from a wrong
# initial guess, compare with the ground truth, and point at the report.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
# The tool alone (124 of the 187 build steps): the test suite is the second README command's.
INSALIGN_TARGETS=insalign bash scripts/build.sh
out=${1:-demo}
build/src/insalign simulate --out "$out/data"
build/src/insalign calibrate --lidar-dir "$out/data/lidar" --poses "$out/data/poses.txt" \
  --init "$out/data/init-extrinsic.json" --fiducials "$out/data/fiducials.txt" --out "$out/result"
build/src/insalign evaluate --gt "$out/data/ground_truth.json" --result "$out/result/extrinsic.json"
echo "Report: $(realpath "$out/result/report.html")"
