#!/usr/bin/env bash
# A screenshot of a report's 3D view (docs/images/viewer.png) with headless Chromium from file://,
# software WebGL, no network: the viewer in full-window mode at the address's state.
#   bash scripts/viewer_screenshot.sh OUT/report.html OUT.png ["extrinsic=0&colour=2"] [WIDTHxHEIGHT]
set -euo pipefail
page=$(realpath "$1")
out=$(realpath -m "$2")
state=${3:-}
size=${4:-800x520}
profile=$(mktemp -d)
trap 'rm -rf "$profile"' EXIT
chromium --headless --no-sandbox --enable-unsafe-swiftshader --use-angle=swiftshader --no-first-run \
  --disable-extensions --disable-background-networking --user-data-dir="$profile" \
  --window-size="${size/x/,}" --screenshot="$out" "file://$page#full${state:+&$state}" > /dev/null 2>&1
echo "$out"
