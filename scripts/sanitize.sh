#!/usr/bin/env bash
# Builds tactres with AddressSanitizer + UndefinedBehaviorSanitizer
# (-DTACTRES_SANITIZE=ON) in build-h-asan and runs the unit and hard-case
# tests (ctest -L "unit|stability"; the opt-in stability-long run is left
# out). Prints how long the build and the tests took.
#
# Usage: bash scripts/sanitize.sh [extra ctest arguments]
# Environment: SANITIZE_BUILD_DIR (default build-h-asan).
# Exit status: ctest's (0 when every test passed with no sanitizer report).
set -euo pipefail
cd "$(dirname "$0")/.."
build=${SANITIZE_BUILD_DIR:-build-h-asan}
t0=$(date +%s)

# RelWithDebInfo: optimised like the real build (the sanitizers see the
# code that ships), with line numbers in the reports. GCC's
# -fsanitize=undefined leaves out float-cast-overflow, the UB that fuzzing
# found twice (a double out of int's range cast to int): add it.
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DTACTRES_SANITIZE=ON \
  -DCMAKE_CXX_FLAGS="-fsanitize=float-cast-overflow" \
  > "$build.configure.log" 2>&1 || { cat "$build.configure.log"; exit 1; }
cmake --build "$build" -j "$(nproc)" --target tactres tactres_util_tests tactres_targets_tests \
  tactres_camera_tests tactres_locate_tests tactres_profiles_tests tactres_simulate_tests \
  tactres_reports_tests tactres_bench_tests tactres_stability_tests
t1=$(date +%s)

# Any report fails its test: UBSan stops at the first finding (GCC's default
# is to print and go on), ASan always does, and leaks count.
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1:strict_string_checks=1}
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$PWD/tests/fuzz/lsan.supp}  # third-party leaks only
status=0
ctest --test-dir "$build" -L 'unit|stability' -LE 'stability-long' --output-on-failure \
  --parallel "$(nproc)" --timeout 3600 "$@" || status=$?
t2=$(date +%s)
echo "sanitize.sh: build $((t1 - t0)) s, tests $((t2 - t1)) s, total $((t2 - t0)) s; ctest exit $status"
exit "$status"
