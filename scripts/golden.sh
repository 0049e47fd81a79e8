#!/usr/bin/env bash
# Golden outputs for a change that must not change behaviour (a refactor):
# runs a built `tactres` on the shipped examples (the nine design scenes in
# layout mode, the example chart in chart mode, the report) and writes every
# JSON and CSV with the timing fields removed, so that two runs compare with
# `diff -r`.
#
# Usage: bash scripts/golden.sh OUT_DIR [TACTRES_BINARY]
#   e.g. before: bash scripts/golden.sh /tmp/golden-before
#        after:  bash scripts/golden.sh /tmp/golden-after && diff -r /tmp/golden-before /tmp/golden-after
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:?usage: golden.sh OUT_DIR [TACTRES_BINARY]}
tactres=${2:-./build/cli/tactres}
rm -rf "$out"
mkdir -p "$out/raw" "$out/golden"
raw=$out/raw

"$tactres" generate --out "$raw/target" > /dev/null
"$tactres" generate --style mil-std-150a --first-group 0 --last-group 5 --out "$raw/chart-target" > /dev/null
for scene in examples/scenes/*.json; do
  name=$(basename "$scene" .json)
  "$tactres" simulate "$scene" --layout "$raw/target/layout.json" -o "$raw/$name.png" > /dev/null
done
"$tactres" simulate examples/charts/usaf1951.json --layout "$raw/chart-target/layout.json" -o "$raw/chart.png" > /dev/null

status=0
"$tactres" measure "$raw"/cmos.png "$raw"/T*.png --layout "$raw/target/layout.json" \
  --camera examples/cameras/wide_angle.cameramodel --out-dir "$raw/measurements" -j 1 > "$raw/measure.txt" || status=$?
"$tactres" measure "$raw/chart.png" --chart usaf1951 -o "$raw/measurements/chart.json" \
  --csv "$raw/measurements/chart.csv" >> "$raw/measure.txt" || status=$?
designs=$(ls "$raw"/measurements/T*.json)
"$tactres" report $designs --reference "$raw/measurements/cmos.json" --csv "$raw/report.csv" > "$raw/report.txt"

# Everything but timings, in a stable form.
python3 - "$raw" "$out/golden" <<'EOF'
import json, pathlib, re, sys
raw, golden = pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2])
def strip(v):
    if isinstance(v, dict):
        return {k: strip(x) for k, x in v.items() if not (k.startswith("timing") or k.endswith("_seconds"))}
    if isinstance(v, list):
        return [strip(x) for x in v]
    return v
for f in sorted(raw.rglob("*")):
    rel = f.relative_to(raw)
    dst = golden / rel
    if f.suffix not in (".json", ".csv", ".txt"):
        continue
    # The output folder differs between runs: call it RAW.
    text = f.read_text().replace(str(raw), "RAW")
    dst.parent.mkdir(parents=True, exist_ok=True)
    if f.suffix == ".json":
        dst.write_text(json.dumps(strip(json.loads(text)), indent=1, sort_keys=True) + "\n")
    else:
        # Summaries carry run times ("in 1.23 s"): drop them.
        dst.write_text(re.sub(r" in [0-9.]+ s", "", text))
EOF
echo "golden outputs in $out/golden (measure exit $status)"
