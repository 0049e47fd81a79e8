#!/usr/bin/env bash
# The main job on the shipped examples: generate the target, simulate the
# bare camera and the eight diffusion-layer designs, measure all nine,
# write the HTML/CSV report, and print where it is.
# Usage: bash scripts/run-examples.sh [OUT_DIR]   (default: ./out)
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh > build.log 2>&1 || { tail -50 build.log; echo "build failed (see build.log)"; exit 1; }
tactres=./build/cli/tactres
out=${1:-out}
mkdir -p "$out"

echo "== generate the target"
"$tactres" generate --out "$out/target"

echo "== simulate the bare camera (cmos) and the eight designs"
mkdir -p "$out/captures"
ls examples/scenes/*.json | xargs -P "$(nproc)" -I{} sh -c \
  'scene={}; name=$(basename "$scene" .json); '"$tactres"' simulate "$scene" --layout '"$out"'/target/layout.json -o '"$out"'/captures/"$name".png --truth '"$out"'/captures/"$name".truth.json'

echo "== measure all nine"
status=0
"$tactres" measure "$out"/captures/*.png --layout "$out/target/layout.json" \
  --camera examples/cameras/wide_angle.cameramodel --out-dir "$out/measurements" || status=$?
if [ "$status" -gt 2 ]; then echo "measure failed with exit $status"; exit "$status"; fi

echo "== report against the raw CMOS limit"
mkdir -p "$out/report"
designs=$(ls "$out"/measurements/*.json | grep -v '/cmos.json$')
"$tactres" report $designs --reference "$out/measurements/cmos.json" \
  --html "$out/report/report.html" --csv "$out/report/report.csv"
echo
echo "Report: $(realpath "$out/report/report.html")"
