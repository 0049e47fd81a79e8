#!/usr/bin/env bash
# Installs every build and test dependency of tactres from Debian's archive.
# Idempotent: safe to run twice, and as the first thing on a fresh Debian 12.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config
  libopencv-dev        # fiducial detection, image ops
  libmrcal-dev         # camera models and projection
  libceres-dev         # pose and profile fits
  libopenimageio-dev   # image I/O
  openimageio-tools    # its CMake config references these binaries (Debian packaging)
  libfmt-dev           # formatting
  doctest-dev          # unit tests
  libcli11-dev         # command line
  nlohmann-json3-dev   # JSON
  libjs-chart.js       # charts, inlined into the HTML report (tactres report)
  chromium             # headless browser for the HTML report's test
  fonts-dejavu-core    # a font for the headless browser
  libtesseract-dev     # OCR of a chart's printed group/element numbers (metrology/labels)
  tesseract-ocr-eng    # its English LSTM model (tessdata); nothing is downloaded at run time
  libfreetype-dev      # labels' tests render digits in real fonts (DejaVu Sans, Liberation Sans)
  fonts-liberation     # Liberation Sans (Arial metrics), the second font of those tests
  clang-14             # libFuzzer targets (scripts/fuzz.sh)
  libclang-rt-14-dev   # libFuzzer and sanitizer runtimes for clang
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
