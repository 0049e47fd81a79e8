#!/usr/bin/env bash
# docs/CHART.md's real photograph: measure a real chart capture from
# ../shared/realdata (never copied into the repository: several sources
# carry no licence) and write its JSON, CSV and overlay beside a link to
# the original, so that CHART.md's images resolve in a checkout.
# Usage: bash scripts/chart-example.sh [OUT_DIR]   (default: build/chart-example)
set -euo pipefail
cd "$(dirname "$0")/.."
realdata=../shared/realdata
if [ ! -d "$realdata" ]; then
  echo "chart-example: $realdata is absent (the real captures are not part of the repository); nothing to do"
  exit 0
fi
[ -x build/cli/tactres ] || bash scripts/build.sh > build.log 2>&1 || { tail -50 build.log; exit 1; }
out=${1:-build/chart-example}
mkdir -p "$out"
for frame in dev_04_orig.png dev_11_orig.png; do
  stem=${frame%.*}
  ln -sf "$(realpath "$realdata/$frame")" "$out/$frame"
  status=0
  ./build/cli/tactres measure "$realdata/$frame" --chart usaf1951 -o "$out/$stem.json" --csv "$out/$stem.csv" \
    --overlay "$out/$stem.overlay.png" || status=$?
  if [ "$status" -gt 2 ]; then echo "measure failed with exit $status"; exit "$status"; fi
done
echo "Overlays: $(realpath "$out")"
