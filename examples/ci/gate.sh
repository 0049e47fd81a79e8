#!/usr/bin/env bash
# Production-line gate: measure every capture in a folder and fail the job
# when any sensor resolves less than the required lp/mm.
#
#   bash examples/ci/gate.sh CAPTURE_DIR LAYOUT.json CAMERA.cameramodel [H_LPMM] [V_LPMM]
#
# Exit code: 0 all within spec, 1 a sensor below spec, 2 an unusable capture,
# 3 usage or I/O error (tactres' own codes; the batch reports the worst).
# Writes results/<capture>.json|.csv|.overlay.png and results/junit.xml,
# which CI systems (GitLab, Jenkins, GitHub Actions reporters) display.
set -uo pipefail
captures=${1:?capture folder}
layout=${2:?layout.json}
camera=${3:?camera model}
require_h=${4:-4.0}
require_v=${5:-4.0}
tactres=${TACTRES:-./build/cli/tactres}

"$tactres" measure "$captures"/*.png --layout "$layout" --camera "$camera" \
  --require-h "$require_h" --require-v "$require_v" \
  --out-dir results --junit results/junit.xml
status=$?
case $status in
  0) echo "gate: PASS (every capture resolves >= $require_h lp/mm H and >= $require_v lp/mm V)" ;;
  1) echo "gate: FAIL (a capture is below spec; see results/junit.xml)" ;;
  2) echo "gate: ERROR (an unusable capture; see the messages above)" ;;
  *) echo "gate: ERROR (usage or I/O, exit $status)" ;;
esac
exit $status
