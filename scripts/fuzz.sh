#!/usr/bin/env bash
# Builds the libFuzzer targets (tests/fuzz, clang with
# -fsanitize=fuzzer,address,undefined) in build-h-fuzz and runs each for a
# bounded time, two at a time (docs/STABILITY.md, "Fuzzing").
#
# Usage: bash scripts/fuzz.sh [SECONDS] [ENTRY...]
#   SECONDS  time per target (default 300)
#   ENTRY    layout_json scene_json measurement_json camera_model image
#            profile_fit measure_raw (default: all)
# Environment: FUZZ_BUILD_DIR (default build-h-fuzz), FUZZ_JOBS (default 2).
#
# New corpus entries go to $FUZZ_BUILD_DIR/fuzz-corpus/<entry>; crashes to
# $FUZZ_BUILD_DIR/fuzz-artifacts/<entry>/ (emptied at the start of each
# run). Replay one with $FUZZ_BUILD_DIR/tests/fuzz_<entry> FILE. Once it is
# fixed, keep it as a regression test in tests/fuzz/regressions/<entry>/:
# the stability suite replays that folder in every normal test run.
# Exit status: 0 when no target found a crash, 1 otherwise.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-300}
shift || true
all=(layout_json scene_json measurement_json camera_model image profile_fit measure_raw)
entries=("$@")
[ ${#entries[@]} -gt 0 ] || entries=("${all[@]}")
build=${FUZZ_BUILD_DIR:-build-h-fuzz}
jobs=${FUZZ_JOBS:-2}

cxx=$(command -v clang++-14 || command -v clang++ || true)
cc=$(command -v clang-14 || command -v clang || true)
[ -n "$cxx" ] && [ -n "$cc" ] || { echo "fuzz.sh: clang is needed (scripts/install-deps.sh installs clang-14)"; exit 3; }

echo "== configure and build $build ($cxx)"
# Every library gets coverage instrumentation (fuzzer-no-link) and the
# sanitizers (TACTRES_SANITIZE); only the fuzz targets link libFuzzer.
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_C_COMPILER="$cc" -DCMAKE_CXX_COMPILER="$cxx" \
  -DCMAKE_C_FLAGS="-fsanitize=fuzzer-no-link" -DCMAKE_CXX_FLAGS="-fsanitize=fuzzer-no-link" \
  -DTACTRES_SANITIZE=ON -DTACTRES_FUZZ=ON > "$build.configure.log" 2>&1 || { cat "$build.configure.log"; exit 3; }
targets=()
for e in "${entries[@]}"; do targets+=("fuzz_$e"); done
cmake --build "$build" --target "${targets[@]}" -j "$(nproc)"

# UBSan findings must stop the run like ASan's; leaks are findings too.
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1}
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$PWD/tests/fuzz/lsan.supp}  # third-party leaks only

run_one() {
  local e=$1
  local corpus="$build/fuzz-corpus/$e" artifacts="$build/fuzz-artifacts/$e/"
  mkdir -p "$corpus" "$artifacts"
  # Artifacts of an earlier run are either fixed (and kept in
  # tests/fuzz/regressions) or found again: start each run clean.
  find "$artifacts" -maxdepth 1 -type f -delete
  # The first folder receives new inputs; the committed seeds and the kept
  # regressions are read too, never written.
  local dirs=("$corpus" "tests/fuzz/corpus/$e")
  [ -d "tests/fuzz/regressions/$e" ] && dirs+=("tests/fuzz/regressions/$e")
  "$build/tests/fuzz_$e" -max_total_time="$seconds" -timeout=60 -rss_limit_mb=4096 -max_len=262144 \
    -print_final_stats=1 -artifact_prefix="$artifacts" "${dirs[@]}" > "$build/fuzz-$e.log" 2>&1 || true
}

echo "== fuzz ${entries[*]}: ${seconds} s each, $jobs at a time"
running=0
for e in "${entries[@]}"; do
  run_one "$e" &
  running=$((running + 1))
  if [ "$running" -ge "$jobs" ]; then
    wait -n
    running=$((running - 1))
  fi
done
wait

status=0
printf '%-18s %12s %10s %8s  %s\n' entry executions exec/s corpus crashes
for e in "${entries[@]}"; do
  log="$build/fuzz-$e.log"
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -1)
  rate=$(grep -o 'stat::average_exec_per_sec: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -1)
  corpus=$(find "$build/fuzz-corpus/$e" -type f | wc -l)
  crashes=$(find "$build/fuzz-artifacts/$e" -type f | wc -l)
  printf '%-18s %12s %10s %8s  %s\n' "$e" "${execs:-?}" "${rate:-?}" "$corpus" "$crashes"
  if [ "$crashes" -gt 0 ] || grep -q 'ERROR: \(libFuzzer\|AddressSanitizer\|LeakSanitizer\)\|runtime error:' "$log"; then
    status=1
    echo "  $e: see $log and $build/fuzz-artifacts/$e/"
  fi
done
exit "$status"
